"""pressure_command: its closed loops over DDS, and its own logic in process.

Over DDS (the wiring): position mode with targets from the ``joint_targets`` topic, and force
mode switched at run time, against the running plant and estimator. One plant, controller and
estimator serve those tests; every test finds the controller in position mode at `TARGETS`
(what a test sets is put back after it).

In process (`reliability_inprocess.InProcessNode`, no DDS traffic): targets outside the range
of motion refused, the range-of-motion back-off reported, and the ramp down reported when the
joint states stop. The controllers and the limiter themselves are tested in tests/test_control.py;
a plant stopped under a running position controller (processes) in
tests/test_reliability_faults.py.
"""

import functools
import itertools
import os
import time

import numpy as np
import pytest
from builtin_interfaces.msg import Time
from diagnostic_msgs.msg import DiagnosticStatus
from rclpy.parameter import Parameter
from ros_harness import wait_until
from rosgraph_msgs.msg import Clock
from sensor_msgs.msg import JointState
from std_msgs.msg import Float64MultiArray

from exodigit_model import GloveModel, load_params

NS = f'/nodes_command_{os.getpid()}'  # unique per session
#: How close a closed loop must settle, rad and N.
ANGLE_SETTLED = 1e-3
FORCE_SETTLED = 1e-3
SETTLE_TIME = 15.0  # s
#: The controller's feedback_timeout (its default), s.
FEEDBACK_TIMEOUT = 0.5
PLANT = {'pressure_time_constant': 0.05}
TARGETS = [0.1, 0.1, 0.1]  # rad, the controller's joint_targets at start
#: The controller at start: position mode.
CONTROLLER = {'mode': 'position', 'joint_targets': TARGETS}
#: The controller's parameters that tests change (put back in this order: targets within limits).
CHANGED = ['mode', 'joint_targets', 'force_targets']


@pytest.fixture(scope='module')
def model():
    return GloveModel(load_params())


def start_loop(launcher, probe, namespace):
    """Plant, position controller at `TARGETS` and estimator in ``namespace``, all heard.

    Returns the nodes, the probe's inboxes of their topics and a ``joint_targets`` publisher.
    """
    inboxes = {
        'joint_states': probe.subscribe(f'{namespace}/joint_states', JointState),
        'estimated_contact_forces': probe.subscribe(
            f'{namespace}/estimated_contact_forces', JointState
        ),
        'pressure_command': probe.subscribe(f'{namespace}/pressure_command', Float64MultiArray),
    }
    nodes = {
        'plant': launcher.start('plant', PLANT, namespace=namespace),
        'pressure_command': launcher.start('pressure_command', CONTROLLER, namespace=namespace),
    }
    nodes['estimator'] = launcher.start('estimator', {}, namespace=namespace)
    heard = inboxes['estimated_contact_forces']
    assert heard.wait_count(1, timeout=30.0), {name: n.stderr() for name, n in nodes.items()}
    return nodes, probe.publisher(f'{namespace}/joint_targets', Float64MultiArray), inboxes


@pytest.fixture(scope='module')
def running(launcher, probe):
    return start_loop(launcher, probe, NS)


@pytest.fixture
def loop(running, probe):
    """The module's loop, with the controller's parameters put back after the test."""
    with probe.parameters_restored(f'{NS}/pressure_command', CHANGED):
        yield running


def settles(inbox, field, target, tolerance, since):
    def close():
        message = inbox.latest()
        values = np.array(getattr(message, field)) if message is not None else None
        return values is not None and np.abs(values - target).max() < tolerance

    return wait_until(lambda: inbox.messages(since) and close(), SETTLE_TIME)


def test_position_mode_reaches_the_targets_sent_on_the_topic(loop):
    _, targets, inboxes = loop
    goal = [0.35, 0.3, 0.2]
    mark = time.monotonic()
    targets.publish(Float64MultiArray(data=goal))
    assert settles(inboxes['joint_states'], 'position', goal, ANGLE_SETTLED, mark), (
        inboxes['joint_states'].latest().position
    )


def test_force_mode_reaches_the_target_contact_forces(loop, probe, model):
    _, _, inboxes = loop
    pressure = [40e3, 20e3, 10e3]  # Pa, inside the limits: the target is reachable
    goal = model.solve(pressure).forces
    results = probe.set_parameters(
        f'{NS}/pressure_command', {'force_targets': goal.tolist(), 'mode': 'force'}
    )
    assert all(r.successful for r in results), [r.reason for r in results]
    mark = time.monotonic()
    assert settles(inboxes['estimated_contact_forces'], 'effort', goal, FORCE_SETTLED, mark), (
        inboxes['estimated_contact_forces'].latest().effort
    )
    # The forward map is one to one: the command found is the pressure the goal came from.
    np.testing.assert_allclose(inboxes['pressure_command'].latest().data, pressure, rtol=1e-2)


# -- in process: the node's own logic -------------------------------------------------------


@pytest.fixture
def in_process(command_nodes):
    """Builds PressureCommand nodes in process (position mode at `TARGETS`); closes them."""
    return functools.partial(command_nodes, TARGETS)


def joint_states(q, t):
    """A joint_states message at angles ``q`` (rad) stamped ``t`` (s)."""
    message = JointState(name=['mcp', 'pip', 'dip'], position=[float(v) for v in q])
    message.header.stamp.sec, message.header.stamp.nanosec = divmod(round(t * 1e9), 10**9)
    return message


def report(node):
    """The node's /diagnostics status now: (status, key -> value)."""
    node.node.report()
    status = node.take()['/diagnostics'][-1].status[0]
    return status, {kv.key: kv.value for kv in status.values}


def test_targets_outside_the_range_of_motion_are_refused(in_process):
    # The controller keeps its targets, and its diagnostics count the refusal; a target is
    # taken at the node's next command.
    node = in_process()
    node.deliver('joint_targets', Float64MultiArray(data=[0.35, 3.0, 0.2]))
    node.node.tick()
    np.testing.assert_array_equal(node.node.loop.controller.targets, TARGETS)
    status, values = report(node)
    assert values['rejected joint_targets: out of range'] == '1'
    assert status.level == DiagnosticStatus.WARN
    node.deliver('joint_targets', Float64MultiArray(data=[0.35, 0.3, 0.2]))  # inside: taken
    node.node.tick()
    np.testing.assert_array_equal(node.node.loop.controller.targets, [0.35, 0.3, 0.2])


def test_leaving_the_range_of_motion_makes_the_controller_back_off_and_say_so(in_process):
    # In lockstep each joint_states is answered by one command at once: no clock involved.
    node = in_process(lockstep='true')
    node.deliver('joint_targets', Float64MultiArray(data=[0.35, 0.3, 0.2]))
    bent = [0.2, 0.2, 0.2]  # rad: the MCP inside the default range, outside the one set below
    for k in range(1, 6):
        node.deliver('joint_states', joint_states(bent, 0.01 * k))
    rising = [m.data[0] for m in node.take()['pressure_command']]
    assert rising[-1] > rising[0] > 0.0
    status, _ = report(node)
    assert 'backing off' not in status.message
    limits = Parameter('joint_upper_limits', value=[0.15, 1.75, 1.4])
    assert node.node.set_parameters([limits])[0].successful
    for k in range(6, 11):
        node.deliver('joint_states', joint_states(bent, 0.01 * k))
    backing = [m.data[0] for m in node.take()['pressure_command']]
    assert backing[0] < rising[-1]
    assert all(b < a for a, b in itertools.pairwise(backing)), backing
    status, values = report(node)
    assert status.level == DiagnosticStatus.WARN and 'backing off' in status.message
    assert int(values['limited steps: back-off']) == 5


def test_without_fresh_joint_states_the_closed_loop_ramps_to_zero_and_says_so(in_process):
    # The node runs on simulated time here (use_sim_time, /clock delivered by hand), so the
    # joint states go stale exactly when the test says.
    node = in_process(use_sim_time='true', max_pressure_rate='100000.0')

    def at(t):
        node.deliver('clock', Clock(clock=Time(sec=int(t), nanosec=round(t % 1 * 1e9))))

    at(100.0)
    node.deliver('joint_states', joint_states([0.0, 0.0, 0.0], 100.0))
    for k in range(1, 11):
        at(100.0 + 0.01 * k)
        node.node.tick()
    held = [max(m.data) for m in node.take()['pressure_command']]
    assert held[-1] > 0.0
    status, _ = report(node)
    assert 'no fresh joint_states' not in status.message
    for k in range(1, 31):
        at(100.1 + FEEDBACK_TIMEOUT + 0.01 * k)  # the last state is older than the timeout
        node.node.tick()
    sent = np.array([m.data for m in node.take()['pressure_command']])
    assert sent.min() >= 0.0 and sent.max() <= held[-1]
    assert list(sent[-1]) == [0.0, 0.0, 0.0]
    status, _ = report(node)
    assert status.level == DiagnosticStatus.WARN and 'no fresh joint_states' in status.message


# -- a new session when time goes back (docs/spec/ros.md, "When time goes back") ---------------

#: A session of states: the finger bending towards the targets, stamped from ``start``.
SESSION_ANGLES = np.linspace([0.0, 0.0, 0.0], [0.08, 0.09, 0.07], 20)


def at(node, t):
    """Deliver ``/clock`` at ``t`` (s) to ``node``."""
    node.deliver('clock', Clock(clock=Time(sec=int(t), nanosec=round(t % 1 * 1e9))))


def lockstep_session(node, start):
    """Answer each state of `SESSION_ANGLES` stamped ``start`` + 0.01 k; the commands sent."""
    for k, q in enumerate(SESSION_ANGLES, start=1):
        node.deliver('joint_states', joint_states(q, start + 0.01 * k))
    return np.array([m.data for m in node.take()['pressure_command']])


def timer_session(node, start):
    """/clock from ``start``, a state and a tick each 0.01 s; the commands sent."""
    at(node, start)
    for k, q in enumerate(SESSION_ANGLES, start=1):
        at(node, start + 0.01 * k)
        node.deliver('joint_states', joint_states(q, start + 0.01 * k))
        node.node.tick()
    return np.array([m.data for m in node.take()['pressure_command']])


@pytest.mark.parametrize('mode', ['position', 'sine'])
def test_in_lockstep_a_state_stamped_back_in_time_starts_a_new_session(in_process, mode):
    # A node that answered a session at t = 5 s answers one from t = 0.01 s again as a node that
    # has just started does: no integral, no rate-limited command, no last stamp carried over,
    # and the session's time (the sine's) from its first state, as a fresh node's.
    fresh = lockstep_session(in_process(lockstep='true', mode=mode), 0.0)
    used = in_process(lockstep='true', mode=mode)
    before = lockstep_session(used, 5.0)
    assert not np.array_equal(before[-1], fresh[0])  # something to forget: integral, limiter
    np.testing.assert_array_equal(lockstep_session(used, 0.0), fresh)


def test_when_the_node_clock_goes_back_the_node_starts_a_new_session(in_process):
    # The same on its own timer, on simulated time: /clock going back is the signal (a time-jump
    # callback on the node clock).
    fresh = timer_session(in_process(use_sim_time='true'), 100.0)
    used = in_process(use_sim_time='true')
    timer_session(used, 200.0)
    np.testing.assert_array_equal(timer_session(used, 100.0), fresh)
