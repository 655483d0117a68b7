"""The closed loops of pressure_command against the running plant and estimator.

Position mode with targets from the ``joint_targets`` topic, force mode switched at run time,
the range-of-motion back-off, and what the controller does when the plant goes away.

One plant, controller and estimator serve the module; every test finds the controller in
position mode at `TARGETS` (what a test sets is put back after it). The tests that leave the
controller capped by a back-off, or stop the plant, have a plant and controller of their own.
"""

import os
import signal
import time

import numpy as np
import pytest
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus
from ros_harness import STOP_TIMEOUT, wait_until
from sensor_msgs.msg import JointState
from std_msgs.msg import Float64MultiArray

from exodigit_model import GloveModel, load_params

NS = f'/nodes_command_{os.getpid()}'  # unique per session
#: How close a closed loop must settle, rad and N.
ANGLE_SETTLED = 1e-3
FORCE_SETTLED = 1e-3
SETTLE_TIME = 15.0  # s
MAX_PRESSURE = 60e3  # Pa, the node's default
#: How far past a range-of-motion limit the lagging chambers may carry a joint, rad.
OVERSHOOT = 0.01
PLANT = {'pressure_time_constant': 0.05}
TARGETS = [0.1, 0.1, 0.1]  # rad, the controller's joint_targets at start
#: The controller at start: position mode, reporting 10 times a second (the tests wait for it).
CONTROLLER = {'mode': 'position', 'joint_targets': TARGETS, 'diagnostic_period': 0.1}
#: The controller's parameters that tests change (put back in this order: targets within limits).
CHANGED = ['mode', 'joint_targets', 'force_targets']


@pytest.fixture(scope='module')
def model():
    return GloveModel(load_params())


def start_loop(launcher, probe, namespace, estimator=True):
    """Plant, position controller at `TARGETS` (and estimator) in ``namespace``, all heard.

    Returns the nodes, the probe's inboxes of their topics and a ``joint_targets`` publisher.
    """
    inboxes = {
        'joint_states': probe.subscribe(f'{namespace}/joint_states', JointState),
        'estimated_contact_forces': probe.subscribe(
            f'{namespace}/estimated_contact_forces', Float64MultiArray
        ),
        'pressure_command': probe.subscribe(f'{namespace}/pressure_command', Float64MultiArray),
        'diagnostics': probe.subscribe('/diagnostics', DiagnosticArray),
    }
    nodes = {
        'plant': launcher.start('plant', PLANT, namespace=namespace),
        'pressure_command': launcher.start('pressure_command', CONTROLLER, namespace=namespace),
    }
    if estimator:
        nodes['estimator'] = launcher.start('estimator', {}, namespace=namespace)
    heard = inboxes['estimated_contact_forces' if estimator else 'pressure_command']
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


@pytest.fixture
def own_loop(launcher, probe, request):
    """A plant and a position controller for this test alone (no estimator), stopped after it."""
    namespace = f'{NS}_{request.node.name}'
    nodes, targets, inboxes = start_loop(launcher, probe, namespace, estimator=False)
    yield namespace, nodes, targets, inboxes
    for node in nodes.values():
        node.stop()


def command_status(inboxes, since, namespace=NS):
    return [
        s
        for array in inboxes['diagnostics'].messages(since)
        for s in array.status
        if s.name == f'{namespace}/pressure_command'
    ]


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


def test_targets_outside_the_range_of_motion_are_refused(loop):
    _, targets, inboxes = loop
    mark = time.monotonic()
    targets.publish(Float64MultiArray(data=[0.35, 3.0, 0.2]))
    refused = wait_until(
        lambda: [
            s
            for s in command_status(inboxes, mark)
            if any(kv.key == 'rejected joint_targets: out of range' for kv in s.values)
        ],
        3.0,
    )
    assert refused
    assert settles(inboxes['joint_states'], 'position', TARGETS, ANGLE_SETTLED, mark)


def test_force_mode_reaches_the_target_contact_forces(loop, probe, model):
    _, _, inboxes = loop
    pressure = [40e3, 20e3, 10e3]  # Pa, inside the limits: the target is reachable
    goal = model.solve(pressure).forces
    results = probe.set_parameters(
        f'{NS}/pressure_command', {'force_targets': goal.tolist(), 'mode': 'force'}
    )
    assert all(r.successful for r in results), [r.reason for r in results]
    mark = time.monotonic()
    assert settles(inboxes['estimated_contact_forces'], 'data', goal, FORCE_SETTLED, mark), (
        inboxes['estimated_contact_forces'].latest().data
    )
    # The forward map is one to one: the command found is the pressure the goal came from.
    np.testing.assert_allclose(inboxes['pressure_command'].latest().data, pressure, rtol=1e-2)


def test_leaving_the_range_of_motion_makes_the_controller_back_off(own_loop, probe):
    namespace, _, targets, inboxes = own_loop
    states = inboxes['joint_states']
    mark = time.monotonic()
    targets.publish(Float64MultiArray(data=[0.35, 0.3, 0.2]))
    assert states.wait_for(lambda m: m.position[0] > 0.2, SETTLE_TIME, since=mark) is not None
    limits = {'joint_upper_limits': [0.15, 1.75, 1.4]}  # the glove's MCP is now outside
    assert all(r.successful for r in probe.set_parameters(f'{namespace}/pressure_command', limits))
    mark = time.monotonic()
    backing_off = wait_until(
        lambda: [
            s for s in command_status(inboxes, mark, namespace) if 'backing off' in s.message
        ],
        5.0,
    )
    assert backing_off and backing_off[-1].level == DiagnosticStatus.WARN
    assert states.wait_for(lambda m: m.position[0] <= 0.15, 10.0, since=mark) is not None
    settled = time.monotonic()
    assert wait_until(lambda: len(states.messages(settled)) >= 150, 10.0)
    overshoot = max(m.position[0] for m in states.messages(settled))
    assert overshoot < 0.15 + OVERSHOOT


def test_without_the_plant_the_closed_loop_ramps_to_zero_and_says_so(own_loop):
    namespace, nodes, _, inboxes = own_loop
    assert inboxes['pressure_command'].wait_for(lambda m: min(m.data) > 0.0, SETTLE_TIME)
    nodes['plant'].signal(signal.SIGINT)
    assert nodes['plant'].wait(STOP_TIMEOUT) == 0
    mark = time.monotonic()
    zero = inboxes['pressure_command'].wait_for(lambda m: max(m.data) == 0.0, 5.0, since=mark)
    assert zero is not None
    sent = np.array([m.data for m in inboxes['pressure_command'].messages(mark)])
    assert sent.min() >= 0.0 and sent.max() <= MAX_PRESSURE
    reported = wait_until(
        lambda: [
            s
            for s in command_status(inboxes, mark, namespace)
            if 'no fresh joint_states' in s.message
        ],
        3.0,
    )
    assert reported and reported[-1].level == DiagnosticStatus.WARN
    assert nodes['pressure_command'].alive()
