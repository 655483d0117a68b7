"""A hand in one process (issue 11): ``hand_nodes`` runs every finger's nodes.

Two fingers in lockstep simulated time, started paused and held at ``RUN_UNTIL``: every
expectation is exact. The controllers run in ``force`` mode, so each answer waits for the
estimate of its step and every step is estimated (in the other modes the estimators are not in
lockstep: at real-time factor 0 on a loaded machine they fell more than the 10 queued states
behind). Each finger's published states are compared bit for bit with an in-process
``GloveSimulation`` of that finger's own model file, stepped with the commands its controller
published; both fingers step on one clock; each keeps its own names and parameters. The probe
counts every step: the session is shorter than the publishers' history.
"""

import time
from types import SimpleNamespace

import numpy as np
import pytest
from diagnostic_msgs.msg import DiagnosticArray
from exodigit_nodes.logic.pacing import TimeSettings
from exodigit_nodes.nodes.qos import RECORD_QOS
from exodigit_nodes.nodes.sim_time import MEASURE_WINDOW, SimulatedTime
from ros_harness import NodeProcess, RosProbe, wait_until
from rosgraph_msgs.msg import Clock
from sensor_msgs.msg import JointState
from std_msgs.msg import Float64MultiArray
from std_srvs.srv import SetBool

from exodigit_model import GloveModel, GloveSimulation, load_params

FINGERS = ('index', 'little')
NAMESPACE = '/hand'
RATE = 100.0
RUN_UNTIL = 0.5
STEPS = round(RUN_UNTIL * RATE)
#: Longest wait for the whole session (start-up of a process with six nodes, 50 steps), s.
TIMEOUT = 60.0


def hand_nodes(domain, workdir, *arguments):
    return NodeProcess('hand_nodes', None, domain, workdir, arguments=list(arguments))


@pytest.fixture(scope='module')
def session(ros_domain, tmp_path_factory):
    """The recorded messages of one lockstep session of two fingers, up to RUN_UNTIL."""
    workdir = tmp_path_factory.mktemp('hand')
    probe = RosProbe(ros_domain, name='hand_probe')
    # Transient-local, as a recorder: the nodes' publishers keep their samples for a reader they
    # match late (a volatile one lost a pressure_command sent before the command node's writer
    # had matched it, though the probe's reader had matched that writer: 49 of 50 in a CI run).
    inboxes = {'/clock': probe.subscribe('/clock', Clock, qos=RECORD_QOS)}
    for finger in FINGERS:
        ns = f'{NAMESPACE}/{finger}'
        inboxes[f'{finger}/joint_states'] = probe.subscribe(
            f'{ns}/joint_states', JointState, qos=RECORD_QOS
        )
        for topic in ('pressure_command', 'chamber_pressure'):
            inboxes[f'{finger}/{topic}'] = probe.subscribe(
                f'{ns}/{topic}', Float64MultiArray, qos=RECORD_QOS
            )
        inboxes[f'{finger}/estimated_contact_forces'] = probe.subscribe(
            f'{ns}/estimated_contact_forces', JointState, qos=RECORD_QOS
        )
    process = hand_nodes(
        ros_domain,
        workdir,
        *('--fingers', ','.join(FINGERS)),
        *('--clock', 'sim', '--lockstep', '--real-time-factor', '0', '--mode', 'force'),
        '--start-paused',
    )
    try:
        # We count every step of a plant at real-time factor 0, unheld: every publisher keeps
        # its last 1,000 samples for a reader that has not acknowledged them, more than the
        # session's STEPS (when they kept 10, a CI run's pressure_command inbox lost one).
        # Any finger's run_until is the hand's.
        held = probe.set_parameters(f'{NAMESPACE}/{FINGERS[0]}/plant', {'run_until': RUN_UNTIL})
        assert all(result.successful for result in held)
        resumed = probe.call(f'{NAMESPACE}/set_paused', SetBool, SetBool.Request(data=False))
        assert resumed.success

        def received_all() -> bool:
            return min(inbox.count() for inbox in inboxes.values()) >= STEPS

        # held at RUN_UNTIL: every state, answer and estimate up to it arrives
        assert wait_until(received_all, TIMEOUT), counts(inboxes)
        parameters = {
            finger: probe.get_parameters(
                f'{NAMESPACE}/{finger}/plant', ['joint_prefix', 'params_file', 'clock']
            )
            for finger in FINGERS
        }
        yield {name: inbox.messages() for name, inbox in inboxes.items()}, parameters, probe
    finally:
        code = process.stop()
        probe.close()
    assert code == 0, process.stderr()


def counts(inboxes) -> str:
    """How many messages each inbox holds, for a failure message."""
    return ', '.join(f'{name} {inbox.count()}' for name, inbox in inboxes.items())


def seconds(stamp) -> float:
    return stamp.sec + 1e-9 * stamp.nanosec


def test_each_finger_has_its_own_names_and_parameters(session):
    messages, parameters, _ = session
    for finger in FINGERS:
        names = messages[f'{finger}/joint_states'][0].name
        assert list(names) == [f'{finger}_mcp', f'{finger}_pip', f'{finger}_dip']
        prefix, files, clock = parameters[finger]
        assert prefix == f'{finger}_'
        assert [f.rsplit('/', 1)[-1] for f in files] == [f'{finger}.yaml']
        assert clock == 'sim'


def test_the_fingers_step_together_on_one_clock(session):
    messages, *_ = session
    grid = [round(k * 1e9 / RATE) for k in range(1, STEPS + 1)]
    for finger in FINGERS:
        stamps = [round(seconds(m.header.stamp) * 1e9) for m in messages[f'{finger}/joint_states']]
        assert stamps == grid  # one state per step, held exactly at RUN_UNTIL
    ticks = [m.clock.sec * 10**9 + m.clock.nanosec for m in messages['/clock']]
    assert ticks == grid  # one /clock per hand step, not one per finger


def replay(finger_model: str, commands) -> np.ndarray:
    """Angles of an in-process stepper of ``finger_model``'s file under ``commands``, rad."""
    simulation = GloveSimulation(GloveModel(load_params([hand_config() / f'{finger_model}.yaml'])))
    return np.array([simulation.step(command).q_measured for command in commands])


def test_each_finger_is_its_own_model_stepped_with_its_own_commands(session):
    messages, *_ = session
    for finger in FINGERS:
        published = np.array([m.position for m in messages[f'{finger}/joint_states']])
        answers = [np.array(m.data) for m in messages[f'{finger}/pressure_command']]
        commands = [np.zeros(3), *answers[: STEPS - 1]]  # step k applies the answer to k - 1
        np.testing.assert_array_equal(published, replay(finger, commands))
        other = next(f for f in FINGERS if f != finger)
        assert np.max(np.abs(published - replay(other, commands))) > 1e-4  # the file matters


def test_every_finger_is_estimated_once_per_step(session):
    messages, *_ = session
    for finger in FINGERS:
        assert len(messages[f'{finger}/estimated_contact_forces']) == STEPS


def test_a_time_setting_set_on_one_finger_is_the_whole_hands(session):
    # The fingers share one simulated time: a finger whose own time setting changes must not
    # push its stale copies of the others (real_time_factor 2 set on one finger, then the
    # lockstep timeout on another, used to put the factor back to 0).
    *_, probe = session
    diagnostics = probe.subscribe('/diagnostics', DiagnosticArray)
    first, second = (f'{NAMESPACE}/{finger}/plant' for finger in FINGERS)
    assert all(r.successful for r in probe.set_parameters(first, {'real_time_factor': 2.0}))
    assert all(r.successful for r in probe.set_parameters(second, {'lockstep_timeout': 3.0}))
    since = time.monotonic()

    def factor_set(message) -> str | None:
        for status in message.status:
            if status.name == second:
                values = {item.key: item.value for item in status.values}
                return values.get('real time factor (set)')
        return None

    report = diagnostics.wait_for(lambda m: factor_set(m) is not None, TIMEOUT, since)
    assert report is not None, 'no simulation report from the second finger'
    assert factor_set(report) == '2'
    # and every finger's parameters say what the hand's time is, whichever finger was told
    for plant in (first, second):
        assert probe.get_parameters(plant, ['real_time_factor', 'lockstep_timeout']) == [2.0, 3.0]


def hand_config():
    from exodigit_nodes.nodes.hand_config import hand_config_dir

    return hand_config_dir()


@pytest.mark.parametrize(
    ('arguments', 'message'),
    [
        (['--fingers', 'index,pinky'], '--fingers index,pinky: give distinct names from thumb,'),
        (['--fingers', 'index,index'], '--fingers index,index: give distinct names'),
        (['--lockstep'], '--lockstep, --start-paused and --real-time-factor need --clock sim'),
        (['--namespace', '/1hand'], "--namespace '/1hand': must be absolute, each name starting"),
    ],
)
def test_a_refused_hand_says_why_in_one_line(ros_domain, tmp_path, arguments, message):
    process = hand_nodes(ros_domain, tmp_path, *arguments)
    assert process.wait(30.0) == 2
    lines = process.stderr().strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith(f'hand_nodes: error: {message}'), lines


def test_fingers_reporting_together_get_one_measured_real_time_factor(probe):
    # Each finger's plant reports its hand's simulated time about once a second, the fingers
    # at nearly the same moment: the second report must not measure over the moment between.
    with probe.local_node('hand_time_test') as owner:
        clock = SimulatedTime(owner, TimeSettings(real_time_factor=0.0))
        fingers = [SimpleNamespace(period=0.01, state=SimpleNamespace(t=0.0)) for _ in FINGERS]
        for finger in fingers:
            clock.add(finger)
        time.sleep(MEASURE_WINDOW)
        for finger in fingers:
            finger.state.t = 1.0
        measured = [clock.status()[1]['real time factor (measured)'] for _ in fingers]
    assert measured[0] == measured[1] and float(measured[0]) > 0.0, measured
