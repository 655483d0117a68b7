"""pressure_command's ``joint_trajectory`` (docs/spec/ros.md, "Trajectories").

In process (`reliability_inprocess.InProcessNode`, its callbacks called directly): the targets
it aims at, one period ahead, against the trajectory sampled from its start; a zero stamp;
``joint_targets`` as a one-point trajectory; each refusal, said in /diagnostics and the log with
the node holding on; a trajectory stamped for the next session kept over a reset.

Over DDS (the testing kit, the node as a process): the node following a trajectory in lockstep
against the same controller code stepped in this process on ``GloveSimulation``, bit for bit,
in a first session and in a second one after ``reset_simulation``.
"""

import functools
import math
import sys

import numpy as np
import pytest
from builtin_interfaces.msg import Duration, Time
from diagnostic_msgs.msg import DiagnosticStatus
from exodigit_model.control import (
    MODE_DEFAULTS,
    CommandLoop,
    Feedback,
    PositionController,
    SafetyLimiter,
    SafetyLimits,
    Trajectory,
)
from exodigit_model.control import trajectory as trajectory_module
from exodigit_model.stepping.settings import step_time_ns
from exodigit_nodes.nodes.messages import trajectory_message
from exodigit_nodes.testing.target_run import TargetGloveSim
from rosgraph_msgs.msg import Clock
from sensor_msgs.msg import JointState
from std_msgs.msg import Float64MultiArray
from trajectory_msgs.msg import JointTrajectory, JointTrajectoryPoint

from exodigit_model import GloveModel, GloveSimulation, SimulationSettings, load_params

SECOND = 10**9
PERIOD = 10_000_000  # ns: the node's default 100 Hz
HELD = [0.3, 0.3, 0.2]  # rad, the node's joint_targets parameter here
NAMES = ['mcp', 'pip', 'dip']
#: Positions and velocities off the step grid: lines and a cubic segment between steps.
PATH = Trajectory(
    [0.0, 0.123, 0.305, 0.5],
    [(0.1, 0.2, 0.1), (0.4, 0.5, 0.3), (0.6, 0.4, 0.35), (0.2, 0.2, 0.1)],
    velocities=[(0.0, 0.0, 0.0), (1.0, 0.5, 0.2), (-0.5, 0.0, 0.1), (0.0, 0.0, 0.0)],
)


@pytest.fixture
def in_process(command_nodes):
    """Builds PressureCommand nodes in process (position mode at `HELD`); closes them."""
    return functools.partial(command_nodes, HELD)


def stamp(t_ns: int) -> Time:
    return Time(sec=t_ns // SECOND, nanosec=t_ns % SECOND)


def state(q, t_ns: int) -> JointState:
    message = JointState(name=NAMES, position=[float(v) for v in q])
    message.header.stamp = stamp(t_ns)
    return message


def targets(node) -> np.ndarray:
    return node.node.loop.controller.targets


def report(node):
    """The node's /diagnostics status now: (status, key -> value)."""
    node.node.report()
    status = node.take()['/diagnostics'][-1].status[0]
    return status, {kv.key: kv.value for kv in status.values}


def test_in_lockstep_it_aims_at_the_trajectory_one_period_past_each_state(in_process):
    node = in_process(lockstep='true')
    start = 7 * SECOND + 3  # any stamp, to the nanosecond
    # the plant's names with a prefix, in another order: the node maps them
    order = [2, 0, 1]
    message = trajectory_message(PATH, start, [f'left_{NAMES[i]}' for i in order])
    for point in message.points:
        point.positions = [point.positions[i] for i in order]
        point.velocities = [point.velocities[i] for i in order]
    node.deliver('joint_trajectory', message)
    for t_ns in (start, start + 5_000_001, start + 120_000_000, start + 300_000_000):
        node.deliver('joint_states', state([0.0, 0.0, 0.0], t_ns))
        np.testing.assert_array_equal(targets(node), PATH.at_ns(t_ns + PERIOD - start))
    node.deliver('joint_states', state([0.0, 0.0, 0.0], start + 2 * SECOND))  # held after it
    np.testing.assert_array_equal(targets(node), PATH.positions[-1])
    assert len(node.take()['pressure_command']) == 5


def test_a_zero_stamp_starts_on_receipt_from_the_target_held(in_process):
    node = in_process(use_sim_time='true')

    def at(t_ns):
        node.deliver('clock', Clock(clock=stamp(t_ns)))

    at(100 * SECOND)
    node.deliver('joint_states', state([0.0, 0.0, 0.0], 100 * SECOND))
    goal = (0.5, 0.5, 0.5)
    line = Trajectory([1.0], [goal])  # one point 1 s after receipt
    node.deliver('joint_trajectory', trajectory_message(line, 0, NAMES))
    at(100 * SECOND + SECOND // 2 - PERIOD)  # the tick aims one period ahead: half way
    node.node.tick()
    np.testing.assert_allclose(targets(node), (np.array(HELD) + goal) / 2, rtol=0, atol=1e-15)
    at(102 * SECOND)
    node.node.tick()
    np.testing.assert_array_equal(targets(node), goal)
    # joint_targets: a one-point trajectory from its receipt, replacing the rest
    node.deliver('joint_targets', Float64MultiArray(data=[0.1, 0.2, 0.3]))
    node.node.tick()
    np.testing.assert_array_equal(targets(node), [0.1, 0.2, 0.3])


def point(positions=(0.1, 0.1, 0.1), t_ns=0, **fields) -> JointTrajectoryPoint:
    return JointTrajectoryPoint(
        positions=list(positions),
        time_from_start=Duration(sec=t_ns // SECOND, nanosec=t_ns % SECOND),
        **fields,
    )


REFUSALS = {
    'unknown joint': (['mcp', 'pip', 'wrist'], [point()], 'joint names'),
    'a joint twice': (['mcp', 'pip', 'pip'], [point()], 'joint names'),
    'two joints': (['mcp', 'pip'], [point()], 'joint names'),
    'no points': (NAMES, [], 'no points'),
    'two positions': (NAMES, [point((0.1, 0.1))], 'lengths'),
    'velocities for some points': (
        NAMES,
        [point(velocities=[0.0, 0.0, 0.0]), point(t_ns=SECOND)],
        'lengths',
    ),
    'accelerations': (NAMES, [point(accelerations=[0.0, 0.0, 0.0])], 'unsupported'),
    'times not increasing': (NAMES, [point(t_ns=SECOND), point(t_ns=SECOND)], 'times'),
    'a negative time': (NAMES, [point(t_ns=-SECOND)], 'times'),
    'NaN': (NAMES, [point((0.1, math.nan, 0.1))], 'non-finite'),
    'outside the range of motion': (NAMES, [point((0.1, 2.0, 0.1))], 'out of range'),
    'too many points': (NAMES, [point(t_ns=k) for k in range(4)], 'too many points'),
}


@pytest.mark.parametrize('case', list(REFUSALS))
def test_a_bad_trajectory_is_refused_whole_said_and_the_node_holds(
    case, in_process, monkeypatch, capfd
):
    monkeypatch.setattr(trajectory_module, 'MAX_POINTS', 3)  # for 'too many points'
    names, points, kind = REFUSALS[case]
    node = in_process(lockstep='true')
    message = JointTrajectory(joint_names=names, points=points)
    node.deliver('joint_trajectory', message)
    node.deliver('joint_states', state([0.0, 0.0, 0.0], SECOND))
    np.testing.assert_array_equal(targets(node), HELD)  # nothing of it taken
    assert len(node.take()['pressure_command']) == 1  # it goes on commanding
    status, values = report(node)
    assert status.level == DiagnosticStatus.WARN
    assert values[f'rejected joint_trajectory: {kind}'] == '1'
    assert 'joint_trajectory' in values['last rejection']
    assert 'dropped a message on joint_trajectory' in capfd.readouterr().err


def lockstep_session(node, start_ns: int, steps: int = 30) -> np.ndarray:
    """Answer states at fixed angles stamped ``start_ns`` + k periods; the commands sent."""
    for k in range(steps):
        node.deliver('joint_states', state([0.1, 0.15, 0.05], start_ns + k * PERIOD))
    return np.array([m.data for m in node.take()['pressure_command']])


def test_a_trajectory_for_the_next_session_is_kept_over_the_reset(in_process):
    # As the testing kit sends it: stamped with the new session's first state, before the
    # reset, to a node that answered a session up to 5 s. It answers the new session as a
    # fresh node given the trajectory first does.
    first = PERIOD
    fresh = in_process(lockstep='true')
    fresh.deliver('joint_trajectory', trajectory_message(PATH, first, NAMES))
    expected = lockstep_session(fresh, first)
    used = in_process(lockstep='true')
    lockstep_session(used, 5 * SECOND)
    used.deliver('joint_trajectory', trajectory_message(PATH, first, NAMES))
    np.testing.assert_array_equal(lockstep_session(used, first), expected)
    # and what it answered followed the trajectory, not the target it held before
    np.testing.assert_array_equal(targets(used), PATH.at_ns(29 * PERIOD + PERIOD))


# -- over DDS: the node as a process, through the testing kit --------------------------------


def in_process_session(steps: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The position mode on `PATH` against GloveSimulation (the kit's plant): q, commands, q0."""
    model = GloveModel(load_params())
    simulation = GloveSimulation(model, SimulationSettings(pressure_time_constant=0.0))
    gains = MODE_DEFAULTS['position']
    controller = PositionController(model, HELD, gains['position_kp'], gains['position_ki'])
    loop = CommandLoop(controller, SafetyLimiter(SafetyLimits()))
    state, start = simulation.state, simulation.state.q_measured
    angles, commands = [], []
    for k in range(steps):
        controller.set_targets(PATH.at_ns(step_time_ns(k + 1, 100.0)))
        command = loop.command(state.t, 0.01, Feedback(state.q_measured)).pressure
        state = simulation.step(command)
        commands.append(command)
        angles.append(state.q_measured)
    return np.array(angles), np.array(commands), start


def test_the_node_following_a_trajectory_in_lockstep_is_the_in_process_controller(tmp_path):
    steps = 60
    angles, commands, start = in_process_session(steps)
    node = [sys.executable, '-m', 'exodigit_nodes.nodes.pressure_command']
    with TargetGloveSim(log_dir=tmp_path) as glove:
        glove.start_controller(node, {'mode': 'position', 'lockstep': True, 'joint_targets': HELD})
        for session in ('first', 'after reset_simulation'):
            record = glove.run_trajectory(PATH, steps / 100.0)
            np.testing.assert_array_equal(record.initial.q, start, err_msg=session)
            np.testing.assert_array_equal(record.command, commands, err_msg=session)
            np.testing.assert_array_equal(record.q, angles, err_msg=session)
            np.testing.assert_array_equal(record.target, PATH.at(np.arange(1, steps + 1) / 100))
    assert np.ptp(angles[:, 1]) > 0.1  # the finger moved along the path
