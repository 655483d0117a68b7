"""The closed loops of pressure_command against the running plant and estimator.

Position mode with targets from the ``joint_targets`` topic, force mode switched at run time,
the range-of-motion back-off, and what the controller does when the plant goes away.
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


@pytest.fixture(scope='module')
def model():
    return GloveModel(load_params())


@pytest.fixture(scope='module')
def loop(launcher, probe):
    inboxes = {
        'joint_states': probe.subscribe(f'{NS}/joint_states', JointState),
        'estimated_contact_forces': probe.subscribe(
            f'{NS}/estimated_contact_forces', Float64MultiArray
        ),
        'pressure_command': probe.subscribe(f'{NS}/pressure_command', Float64MultiArray),
        'diagnostics': probe.subscribe('/diagnostics', DiagnosticArray),
    }
    nodes = {
        'plant': launcher.start('plant', {'pressure_time_constant': 0.05}, namespace=NS),
        'pressure_command': launcher.start(
            'pressure_command',
            {'mode': 'position', 'joint_targets': [0.1, 0.1, 0.1]},
            namespace=NS,
        ),
        'estimator': launcher.start('estimator', {}, namespace=NS),
    }
    targets = probe.publisher(f'{NS}/joint_targets', Float64MultiArray)
    assert inboxes['estimated_contact_forces'].wait_count(1, timeout=30.0), {
        name: node.stderr() for name, node in nodes.items()
    }
    return nodes, targets, inboxes


def command_status(inboxes, since):
    return [
        s
        for array in inboxes['diagnostics'].messages(since)
        for s in array.status
        if s.name == f'{NS}/pressure_command'
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
    assert settles(inboxes['joint_states'], 'position', [0.35, 0.3, 0.2], ANGLE_SETTLED, mark)


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


def test_leaving_the_range_of_motion_makes_the_controller_back_off(loop, probe):
    _, _, inboxes = loop
    limits = {'joint_upper_limits': [0.15, 1.75, 1.4], 'mode': 'position'}
    assert all(r.successful for r in probe.set_parameters(f'{NS}/pressure_command', limits))
    mark = time.monotonic()
    backing_off = wait_until(
        lambda: [s for s in command_status(inboxes, mark) if 'backing off' in s.message], 5.0
    )
    assert backing_off and backing_off[-1].level == DiagnosticStatus.WARN
    states = inboxes['joint_states']
    assert states.wait_for(lambda m: m.position[0] <= 0.15, 10.0, since=mark) is not None
    settled = time.monotonic()
    assert wait_until(lambda: len(states.messages(settled)) >= 150, 10.0)
    overshoot = max(m.position[0] for m in states.messages(settled))
    assert overshoot < 0.15 + OVERSHOOT


def test_without_the_plant_the_closed_loop_ramps_to_zero_and_says_so(loop):
    nodes, _, inboxes = loop
    nodes['plant'].signal(signal.SIGINT)
    assert nodes['plant'].wait(STOP_TIMEOUT) == 0
    mark = time.monotonic()
    zero = inboxes['pressure_command'].wait_for(lambda m: max(m.data) == 0.0, 5.0, since=mark)
    assert zero is not None
    sent = np.array([m.data for m in inboxes['pressure_command'].messages(mark)])
    assert sent.min() >= 0.0 and sent.max() <= MAX_PRESSURE
    reported = wait_until(
        lambda: [s for s in command_status(inboxes, mark) if 'no fresh joint_states' in s.message],
        3.0,
    )
    assert reported and reported[-1].level == DiagnosticStatus.WARN
    assert nodes['pressure_command'].alive()
