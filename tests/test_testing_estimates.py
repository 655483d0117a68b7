"""The testing kit pairs a state with the estimate stamped with it (docs/spec/ros.md, Part II).

The estimator answers from its own process: after ``GloveSim.run()`` the estimates of the run's
last states may still be on their way when the test takes its next ``step``. Paired by order,
such a late estimate became the next state's. Here the kit's node is fed the messages directly,
in the orders that happen.
"""

import os

import numpy as np
import pytest
from builtin_interfaces.msg import Time
from exodigit_nodes.testing.ros_client import GloveClient
from sensor_msgs.msg import JointState
from std_msgs.msg import Float64MultiArray, Header

PERIOD_NS = 10_000_000


@pytest.fixture
def client(probe):
    node = GloveClient(
        f'/kit_estimates_{os.getpid()}', probe.context, estimator=True, rate_hz=100, valves=False
    )
    yield node
    node.destroy_node()


def stamped(step):
    return Header(stamp=Time(sec=1, nanosec=step * PERIOD_NS))


def send_state(client, step):
    """The plant's outputs of ``step``: values ``step`` in every element, stamped."""
    values = np.full(3, float(step))
    client._joint_queue(JointState(header=stamped(step), position=values))
    for topic in ('chamber_pressure', 'contact_forces', 'segment_lengths'):
        client._vector_queue(topic)(Float64MultiArray(data=values))


def send_estimate(client, step):
    """The estimator's estimate of ``step``: forces 10 · ``step``."""
    client._estimate_queue(JointState(header=stamped(step), effort=np.full(3, 10.0 * step)))


def test_a_step_after_a_run_gets_its_own_estimate_not_a_late_one_of_the_run(client):
    send_state(client, 1)  # the run's last state, taken without its estimate
    assert client.take_state(with_estimate=False).q[0] == 1.0
    send_state(client, 2)  # the next step's state, then the run's late estimate, then its own
    send_estimate(client, 1)
    assert client.take_state() is None  # not with step 1's estimate: waits for its own
    send_estimate(client, 2)
    state = client.take_state()
    assert state.q[0] == 2.0
    np.testing.assert_array_equal(state.estimated_forces, [20.0, 20.0, 20.0])


def test_an_estimate_that_comes_before_its_state_waits_for_it(client):
    send_estimate(client, 3)
    assert client.take_state() is None
    send_state(client, 3)
    state = client.take_state()
    assert state.t == pytest.approx(1.03)
    np.testing.assert_array_equal(state.estimated_forces, [30.0, 30.0, 30.0])


def test_a_state_the_estimator_never_answered_does_not_block_the_next_one(client):
    # The estimator missed the first state (its reader matched too late, fresh clone under
    # load): a reset's state behind it, estimated, is taken; before, every later reset waited.
    send_state(client, 1)
    assert client.take_state() is None  # its estimate may still come
    send_state(client, 2)
    send_estimate(client, 2)  # the estimator answers in order: step 1's never will
    state = client.take_state()
    assert state.q[0] == 2.0
    np.testing.assert_array_equal(state.estimated_forces, [20.0, 20.0, 20.0])
    assert client.take_state(with_estimate=False) is None  # step 1 is gone, not kept for later
