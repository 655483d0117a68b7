"""The ``hardware`` bridge node against ``mcu_emulator`` over a real pseudo-terminal, both as the
processes a user runs: its topics, and each fault of docs/spec/hardware.md §7 with the
behaviour it names."""

import itertools
import time

import numpy as np
import pytest
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus
from exodigit_nodes.nodes.qos import RECORD_APPLIED_QOS, RECORD_QOS
from ros_harness import wait_until
from running_emulator import RunningEmulator
from sensor_msgs.msg import JointState
from std_msgs.msg import Float64MultiArray

VENT = [0.0, 0.0, 0.0, 1.0, 1.0, 1.0]
FILL = [0.6, 0.3, 1.0, 0.0, 0.0, 0.0]
OPEN = [1.0, 1.0, 1.0, 0.0, 0.0, 0.0]
START = 30.0
"""Longest wait for a process to be up (the emulator loads the model's kernels), s."""


@pytest.fixture
def emulator(request, tmp_path):
    """The board, in a thread of this process (the kit's EmulatorProcess: the kit's test)."""
    board = RunningEmulator(tmp_path, duration=120.0, **getattr(request, 'param', {}))
    yield board
    board.stop()


class Glove:
    """The bridge's topics under one namespace, recorded by the probe."""

    def __init__(self, probe, namespace: str) -> None:
        self.pressure = probe.subscribe(f'{namespace}/chamber_pressure', Float64MultiArray)
        # the record of commands, whole from the bridge's start (transient-local, as the plant's)
        self.applied = probe.subscribe(
            f'{namespace}/applied_command', Float64MultiArray, qos=RECORD_APPLIED_QOS
        )
        self.joints = probe.subscribe(f'{namespace}/joint_states', JointState)
        self.diagnostics = probe.subscribe('/diagnostics', DiagnosticArray, qos=RECORD_QOS)
        self.namespace = namespace
        self.command = probe.publisher(f'{namespace}/valve_command', Float64MultiArray, 0)

    def send(self, openings) -> None:
        self.command.publish(Float64MultiArray(data=list(map(float, openings))))

    def status(self, predicate, timeout: float = 10.0, since: float = -1.0):
        """The first status of our bridge (after ``since``) that satisfies ``predicate``."""

        def ours(array):
            return any(
                s.name.endswith(f'{self.namespace}/hardware') and predicate(s)
                for s in array.status
            )

        array = self.diagnostics.wait_for(ours, timeout, since)
        if array is None:
            return None
        return next(s for s in array.status if s.name.endswith(f'{self.namespace}/hardware'))


def values(status) -> dict:
    return {item.key: item.value for item in status.values}


def start_bridge(launcher, probe, emulator, namespace, **parameters):
    bridge = launcher.start(
        'hardware',
        {'port': emulator.link, 'diagnostic_period': 0.2, **parameters},
        namespace=namespace,
    )
    glove = Glove(probe, namespace)
    assert glove.pressure.wait_count(5, START), bridge.stderr()
    assert wait_until(lambda: glove.command.get_subscription_count() >= 1, START)
    return bridge, glove


def test_a_session_through_the_bridge_applies_every_command_and_reports_the_board(
    launcher, probe, emulator
):
    # no pressure limit here (the supply's 100 kPa is below it), and timeouts no stall of a
    # loaded machine reaches (a 0.1 s gap in the samples vented once in a full suite run): every
    # answer is the command
    bridge, glove = start_bridge(
        launcher, probe, emulator, '/hw_session',
        max_pressure=200e3, sample_timeout=5.0, command_timeout=30.0,
    )  # fmt: skip
    # the record starts with the vent, as the plant's: what the board was told before any command.
    # It reaches this late reader once its own applied_command matches, which the pressure
    # stream's samples do not say (seed 4062955477 beside two busy cores found none yet).
    assert glove.applied.wait_count(1, START)
    assert list(glove.applied.messages()[0].data) == VENT
    # each command once the last is answered: the bridge's reader keeps the latest 10 (a
    # controller wants the latest), so a stalled bridge would drop older ones, not answer them
    sent = []
    for k in range(30):
        openings = FILL if k < 20 else [0.0, 0.0, 0.0, 0.0, 0.5, 0.0]
        openings = [round(value * (1.0 - 0.01 * (k % 3)), 4) for value in openings]
        before = time.monotonic()
        glove.send(openings)
        sent.append(openings)
        answer = glove.applied.wait_for(lambda m, o=openings: list(m.data) == o, 5.0, before)
        assert answer is not None, (k, [list(m.data) for m in glove.applied.messages()][-3:])
        if k == 19:  # the DIP inlet wide open since: it fills
            assert glove.pressure.wait_for(lambda m: m.data[2] > 20e3, 10.0) is not None
    assert [list(m.data) for m in glove.applied.messages()][-len(sent) :] == sent
    pressures = np.array([m.data for m in glove.pressure.messages()])
    assert np.all(np.isfinite(pressures))
    assert np.all(pressures % 50.0 == 0.0)  # the emulator's sensor quantum
    assert pressures[:, 2].max() > 20e3  # DIP filled
    joints = glove.joints.messages()
    assert joints and all(len(m.position) == 3 and m.name[0] == 'mcp' for m in joints)
    stamps = [m.header.stamp.sec + 1e-9 * m.header.stamp.nanosec for m in joints]
    assert all(b >= a for a, b in itertools.pairwise(stamps))  # never back
    assert len(set(stamps)) > 0.9 * len(stamps)  # shared only by samples read in one burst
    assert abs(stamps[-1] - time.time()) < 5.0  # on the host's clock
    status = glove.status(lambda s: s.level == DiagnosticStatus.OK)
    assert status is not None
    report = values(status)
    assert report['link'] == 'streaming' and report['bend_sensors'] == '3'
    assert report['frames_bad'] == '0' and int(report['samples']) > 20
    # a command it refuses (five openings) is answered with those in force, which the board keeps
    before = time.monotonic()
    glove.send(sent[-1][:5])
    assert glove.applied.wait_for(lambda m: list(m.data) == sent[-1], 5.0, before) is not None
    assert emulator.status().openings == pytest.approx(sent[-1])
    assert bridge.stop() == 0


@pytest.mark.parametrize('emulator', [{'bend_sensors': False}], indirect=True)
def test_a_board_without_bend_sensors_gets_no_joint_states(launcher, probe, emulator):
    bridge, glove = start_bridge(launcher, probe, emulator, '/hw_no_bend')
    status = glove.status(lambda s: values(s).get('bend_sensors') == '0')
    assert status is not None
    assert probe.node.count_publishers('/hw_no_bend/joint_states') == 0
    assert glove.joints.count() == 0
    assert bridge.stop() == 0


@pytest.mark.parametrize('emulator', [{'watchdog': 30.0}], indirect=True)
def test_the_bridge_vents_when_the_controller_stops_and_when_it_exits(launcher, probe, emulator):
    # The board's watchdog is 30 s here: every vent seen is the bridge's own.
    bridge, glove = start_bridge(launcher, probe, emulator, '/hw_vent', command_timeout=0.3)
    glove.send(FILL)
    assert wait_until(lambda: emulator.status().openings == pytest.approx(FILL), 5.0)
    # no more commands: within the command timeout and a few samples, the vent
    assert glove.applied.wait_for(lambda m: list(m.data) == VENT, 3.0) is not None
    assert wait_until(lambda: emulator.status().openings == tuple(VENT), 3.0)
    glove.send(FILL)
    assert wait_until(lambda: emulator.status().openings == pytest.approx(FILL), 5.0)
    assert bridge.stop() == 0
    status = emulator.status()
    assert status.openings == tuple(VENT) and not status.watchdog_tripped
    assert 'vented and closed the port' in bridge.stderr()


@pytest.mark.parametrize('emulator', [{'watchdog': 30.0}], indirect=True)
def test_a_pressure_limit_brings_a_chamber_back_whatever_is_commanded(launcher, probe, emulator):
    # Every inlet wide open all along: unlimited, DIP would fill to the supply (100 kPa) and stay
    # there. Neither the board's watchdog (30 s here) nor the bridge's own vents (long timeouts)
    # can empty it: only the limit, closing its inlet and opening its outlet, brings it back.
    bridge, glove = start_bridge(
        launcher, probe, emulator, '/hw_limit',
        max_pressure=20e3, command_timeout=60.0, sample_timeout=30.0,
    )  # fmt: skip

    def back_below_the_limit() -> bool:
        glove.send(OPEN)
        dip = [m.data[2] for m in glove.pressure.messages()]
        over = next((k for k, p in enumerate(dip) if p >= 20e3), None)
        return over is not None and min(dip[over:]) < 20e3

    assert wait_until(back_below_the_limit, 15.0, interval=0.02)
    limited = glove.applied.wait_for(lambda m: m.data[2] == 0.0 and m.data[5] == 1.0, 5.0)
    assert limited is not None  # DIP at the limit: inlet closed, outlet open
    status = glove.status(lambda s: int(values(s)['pressure_limited']) > 0)
    assert status is not None and values(status)['vents'] == '0'
    assert bridge.stop() == 0
    assert 'at or above max_pressure 20000 Pa' in bridge.stderr()


def test_an_unplugged_board_is_an_error_then_found_again_and_vented(launcher, probe, emulator):
    bridge, glove = start_bridge(launcher, probe, emulator, '/hw_unplug')
    glove.send(FILL)
    assert glove.applied.wait_for(lambda m: list(m.data) == FILL, 5.0) is not None
    before = time.monotonic()
    emulator.command('unplug 1.5')
    status = glove.status(lambda s: s.level == DiagnosticStatus.ERROR, 5.0, before)
    assert status is not None and 'board link' in status.message
    assert glove.applied.wait_for(lambda m: list(m.data) == VENT, 5.0, before) is not None
    back = glove.status(
        lambda s: s.level == DiagnosticStatus.OK and values(s)['sessions'] == '2', 15.0, before
    )
    assert back is not None, bridge.stderr()
    # the old command is not applied again: the board holds the vent until a new one
    assert emulator.status().openings == tuple(VENT)
    glove.send(FILL)
    assert wait_until(lambda: emulator.status().openings == pytest.approx(FILL), 5.0)
    assert bridge.stop() == 0
    log = bridge.stderr()
    assert 'board link lost' in log and 'venting' in log and '(session 2: vented)' in log


@pytest.mark.parametrize(
    'emulator', [{'corrupt_probability': 0.01, 'drop_probability': 0.005}], indirect=True
)
def test_a_noisy_line_costs_frames_and_the_bridge_goes_on(launcher, probe, emulator):
    bridge, glove = start_bridge(launcher, probe, emulator, '/hw_noise', sample_timeout=0.5)
    for _ in range(50):
        glove.send(FILL)
        time.sleep(0.02)
    status = glove.status(lambda s: int(values(s)['frames_bad']) > 0, 10.0)
    assert status is not None
    pressures = np.array([m.data for m in glove.pressure.messages()])
    assert len(pressures) > 50 and np.all(np.isfinite(pressures))
    assert bridge.stop() == 0


@pytest.mark.parametrize('emulator', [{'version': 2}], indirect=True)
def test_a_board_of_another_version_stops_the_start_with_one_line(launcher, emulator):
    code, _, stderr = launcher.run('hardware', {'port': emulator.link}, timeout=START)
    assert code == 2
    lines = [line for line in stderr.splitlines() if line.strip()]
    assert len(lines) == 1 and 'protocol version 2' in lines[0] and 'version 1' in lines[0]
    assert 'Traceback' not in stderr


def test_a_port_that_does_not_exist_is_an_error_not_a_crash(launcher, probe, tmp_path):
    # at start it tries an absent port for handshake_timeout (it may yet appear), then says so
    parameters = {
        'port': str(tmp_path / 'none'),
        'diagnostic_period': 0.2,
        'handshake_timeout': 0.5,
    }
    bridge = launcher.start('hardware', parameters, namespace='/hw0')
    diagnostics = probe.subscribe('/diagnostics', DiagnosticArray, qos=RECORD_QOS)
    found = diagnostics.wait_for(
        lambda a: any(
            s.name.endswith('/hw0/hardware') and s.level == DiagnosticStatus.ERROR
            for s in a.status
        ),
        START,
    )
    assert found is not None
    assert bridge.stop() == 0 and 'Traceback' not in bridge.stderr()
