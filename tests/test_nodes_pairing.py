"""The estimator pairs angles with pressures by the time they were sent, not by sequence number.

The node is built in this process and its subscription callbacks are handed messages with the
message info rclpy would give (`reliability_inprocess`), so each case controls exactly when a
message was sent and which sequence number its publisher gave it. Every step has its own
pressures, and the estimate of a step is the model's estimate from that step's angles and
pressures (docs/spec/model.md §7): an estimate from angles and pressures of two steps matches no
step.
"""

import time

import numpy as np
import pytest
from builtin_interfaces.msg import Time
from exodigit_nodes.logic.estimation import SamplePairer
from exodigit_nodes.nodes.estimator import Estimator
from reliability_inprocess import InProcessNode, wire_copy
from sensor_msgs.msg import JointState
from std_msgs.msg import Float64MultiArray

from exodigit_model import GloveModel, load_params

PERIOD = 0.01  # s between two steps
#: Estimates against the model's own estimate of the same angles and pressures, N.
FORCE_TOLERANCE = 1e-12


@pytest.fixture(scope='module')
def model():
    return GloveModel(load_params())


@pytest.fixture(scope='module')
def steps(model):
    """(angles, pressure) of 12 plant steps: the model's solve of 12 different pressures."""
    pressures = [np.array([5e3, 3e3, 2e3]) * (k + 1) for k in range(12)]
    return [(model.solve(p).q, p) for p in pressures]


@pytest.fixture
def estimator(probe):
    node = InProcessNode(Estimator, {}, probe)
    yield node
    node.close()


class Publisher:
    """One publisher's messages as the estimator receives them: numbered 1, 2, ... (DDS)."""

    def __init__(self, node: InProcessNode, topic: str) -> None:
        _, self.callback = node.subscriptions()[topic]
        self.topic = topic
        self.number = 0

    def lose(self) -> None:
        """A message sent but never received (its number is skipped)."""
        self.number += 1

    def send(self, values, sent: float, stamp_age: float = 0.0) -> None:
        """Deliver ``values`` sent at ``sent`` (s); angles stamped ``stamp_age`` s ago."""
        self.number += 1
        if self.topic == 'joint_states':
            now = time.time() - stamp_age  # the node runs on the wall clock
            message = JointState(name=['mcp', 'pip', 'dip'], position=list(values))
            message.header.stamp = Time(sec=int(now), nanosec=int(now % 1 * 1e9))
        else:
            message = Float64MultiArray(data=list(values))
        info = {
            'source_timestamp': round(sent * 1e9),
            'received_timestamp': time.time_ns(),
            'publication_sequence_number': self.number,
            'reception_sequence_number': self.number,
        }
        self.callback(wire_copy(message), info)


def send_steps(node, steps, indices, start, *, player=None, angles_only=()):
    """The plant's pressure then angles of each step in ``indices``, ``PERIOD`` apart."""
    pressure, angles = player or (
        Publisher(node, 'chamber_pressure'),
        Publisher(node, 'joint_states'),
    )
    for k in indices:
        sent = start + PERIOD * k
        if k not in angles_only:
            pressure.send(steps[k][1], sent)
        angles.send(steps[k][0], sent + 50e-6)


def estimated_steps(node, model, steps):
    """The step each published estimate is the estimate of (None: of no step)."""
    expected = [model.estimate_forces(q, p) for q, p in steps]
    found = []
    for message in node.take().get('estimated_contact_forces', []):
        errors = [np.abs(np.array(message.effort) - f).max() for f in expected]
        found.append(int(np.argmin(errors)) if min(errors) <= FORCE_TOLERANCE else None)
    return found


def test_a_replayed_bag_is_estimated_step_by_step_though_its_sequence_numbers_restart(
    estimator, model, steps
):
    send_steps(estimator, steps, range(6), 1000.0)
    assert estimated_steps(estimator, model, steps) == list(range(6))
    # The bag began between step 1's pressure and its angles; the player numbers from 1 again
    # (its angles of step 1 and its pressure of step 2 both 1) and sends an hour later.
    send_steps(estimator, steps, range(1, 6), 4600.0, angles_only={1})
    assert estimated_steps(estimator, model, steps) == [2, 3, 4, 5]


def test_pressure_at_50_hz_is_estimated_with_the_angles_sent_after_it_at_100_hz(
    estimator, model, steps
):
    pressure = Publisher(estimator, 'chamber_pressure')
    angles = Publisher(estimator, 'joint_states')
    for k in range(12):
        if k % 2 == 0:
            pressure.send(steps[k][1], 1000.0 + PERIOD * k)
        angles.send(steps[k][0], 1000.0 + PERIOD * k + 50e-6)
    assert estimated_steps(estimator, model, steps) == [0, 2, 4, 6, 8, 10]


def test_angles_sent_late_by_a_preempted_plant_are_estimated_with_their_own_pressure(
    estimator, model, steps
):
    # Step 3's angles come 27 ms after its pressure; steps 4 and 5 follow 0.5 ms apart.
    pressure = Publisher(estimator, 'chamber_pressure')
    angles = Publisher(estimator, 'joint_states')
    sent = {0: 0.0, 1: 0.01, 2: 0.02, 3: 0.03, 4: 0.0575, 5: 0.058, 6: 0.07}
    for k, t in sent.items():
        pressure.send(steps[k][1], 1000.0 + t)
        angles.send(steps[k][0], 1000.0 + t + (27e-3 if k == 3 else 50e-6))
    assert estimated_steps(estimator, model, steps) == list(range(7))


def test_refused_angles_leave_their_pressure_unpaired_not_paired_with_the_next_step(
    estimator, model, steps
):
    pressure = Publisher(estimator, 'chamber_pressure')
    angles = Publisher(estimator, 'joint_states')
    for k in range(5):
        pressure.send(steps[k][1], 1000.0 + PERIOD * k)
        angles.send(steps[k][0], 1000.0 + PERIOD * k + 50e-6, stamp_age=5.0 if k == 2 else 0.0)
    assert estimated_steps(estimator, model, steps) == [0, 1, 3, 4]
    assert estimator.node.rejections.total == 1


def test_angles_after_lost_messages_pair_with_nothing(estimator, model, steps):
    # Behind, the node lost step 3's angles and step 4's pressure: by time alone step 3's
    # pressure would go with step 4's angles; the gap in the angles' numbering says otherwise.
    pressure = Publisher(estimator, 'chamber_pressure')
    angles = Publisher(estimator, 'joint_states')
    for k in range(7):
        sent = 1000.0 + PERIOD * k
        if k == 4:
            pressure.lose()
        else:
            pressure.send(steps[k][1], sent)
        if k == 3:
            angles.lose()
        else:
            angles.send(steps[k][0], sent + 50e-6)
    assert estimated_steps(estimator, model, steps) == [0, 1, 2, 5, 6]


def test_the_first_angles_heard_pair_with_nothing_when_their_pressure_comes_after_them(
    estimator, model, steps
):
    # The node's two readers met the running plant at different times: the pressure reader
    # heard it from step 3, the angles reader from step 4 (its step 3 was sent before). Two
    # readers keep no order between them, and step 4's angles were taken before step 4's
    # pressure. By time alone step 3's pressure would go with step 4's angles; nothing before
    # the first angles heard says their predecessor was received.
    pressure = Publisher(estimator, 'chamber_pressure')
    angles = Publisher(estimator, 'joint_states')
    for _ in range(3):
        pressure.lose()  # steps 0-2: sent before the pressure reader matched
    for _ in range(4):
        angles.lose()  # steps 0-3: sent before the angles reader matched
    pressure.send(steps[3][1], 1000.0 + PERIOD * 3)
    angles.send(steps[4][0], 1000.0 + PERIOD * 4 + 50e-6)
    pressure.send(steps[4][1], 1000.0 + PERIOD * 4)
    send_steps(estimator, steps, range(5, 8), 1000.0, player=(pressure, angles))
    assert estimated_steps(estimator, model, steps) == [5, 6, 7]


@pytest.mark.parametrize(('trust_first', 'pairs'), [(True, 1), (False, 0)])
def test_a_node_in_lockstep_pairs_the_first_angles_it_hears(steps, trust_first, pairs):
    # The plant published its rest state (step 1) before the controller matched; a lockstep
    # plant then steps only once the controller has matched both topics, so the first angles
    # heard (number 2) follow their own pressure, and the controller must answer them.
    pairer = SamplePairer(0.1, trust_first=trust_first)
    (angles, pressure), sent = steps[1], 1000.0
    assert pairer.add_pressure(pressure, sent) == []
    made = pairer.add_angles(angles, sent + 50e-6, 2)
    assert len(made) == pairs
    for pair in made:
        np.testing.assert_array_equal(pair.angles, angles)
        np.testing.assert_array_equal(pair.pressure, pressure)


@pytest.mark.parametrize(('tolerance', 'estimated'), [(0.1, [0, 1, 2, 3]), (0.02, [0, 1, 3])])
def test_angles_later_than_the_pairing_tolerance_pair_with_nothing(
    probe, model, steps, tolerance, estimated
):
    # Step 2's angles come 30 ms after its pressure (the next pressure 40 ms after it).
    node = InProcessNode(Estimator, {'pairing_tolerance': repr(tolerance)}, probe)
    try:
        pressure = Publisher(node, 'chamber_pressure')
        angles = Publisher(node, 'joint_states')
        for k, t in enumerate([0.0, 0.01, 0.02, 0.06]):
            pressure.send(steps[k][1], 1000.0 + t)
            angles.send(steps[k][0], 1000.0 + t + (30e-3 if k == 2 else 50e-6))
        assert estimated_steps(node, model, steps) == estimated
    finally:
        node.close()
