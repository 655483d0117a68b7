"""Faults in a running glove: kill -9 and restart each node, the plant under a closed loop.

One session (namespace ``/faults``, controller in ``sine`` mode) goes through: normal; kill the
plant while the controller runs in ``position`` mode (with no fresh joint_states it says so in
diagnostics and ramps down to zero, never rising, within its limits), restart it, back to
``sine``, normal again; kill the controller (the plant vents on its watchdog and says so),
restart it, normal; kill the estimator (plant and controller carry on), restart it (forces at
once, stiffness within one identification window), normal. "Normal" is checked against the
model (see `reliability_session.GloveSession.normal`); no manual step is ever taken between
faults.

The closed-loop fault runs in the one session (its controller switched to ``position`` mode
for it) rather than in a second session of processes of its own: two fewer node processes.
"""

import itertools
import math
import time

import pytest
from reliability_session import (
    IDENTIFICATION_PERIOD,
    NODES,
    RATE,
    START_TIMEOUT,
    WINDOW,
    GloveSession,
)
from ros_harness import wait_until

#: Plant command timeout (its default), s; venting is complete well within two of them + lag.
COMMAND_TIMEOUT = 0.5
#: A vented chamber holds less than this, Pa.
VENTED = 100.0
#: How long to watch the survivors of a kill, s: past every timeout of theirs (0.5 s), so a
#: survivor that needed the killed node would have shown it.
WATCH = 1.0
#: Controller feedback timeout (its default), s, and its diagnostics period, s.
FEEDBACK_TIMEOUT = 0.5
REPORT_PERIOD = 1.0
#: The controller's rate limit while in position mode, Pa/s: slow enough that its ramp down
#: lasts past the moment its feedback is surely stale.
RAMP_RATE = 20e3
#: The pressure position mode must hold before the plant is killed, Pa.
HOLDING = 10e3
#: Plant steps of jitter allowed on one window (a late identification tick, delivery to the
#: probe); an estimator that needed a second window would take WINDOW more.
DELIVERY_SLACK = 25


@pytest.fixture(scope='module')
def session(launcher, probe):
    """The ``/faults`` glove, normal."""
    glove = GloveSession(launcher, probe, '/faults')
    for node in NODES:
        glove.start(node)
    problems = glove.normal(since=-1.0, timeout=2 * START_TIMEOUT)
    assert problems == [], f'glove not normal at start: {problems}'
    return glove


def restart_and_recover(session: GloveSession, node: str) -> None:
    restarted = time.monotonic()
    session.start(node)
    problems = session.normal(since=restarted)
    assert problems == [], f'after restarting {node}: not normal: {problems}'


def test_plant_killed_under_a_closed_loop_it_reports_ramps_down_never_rising_then_recovers(
    session,
):
    controller = f'{session.namespace}/pressure_command'
    commands = session.inbox['pressure_command']
    with session.probe.parameters_restored(controller, ['mode', 'max_pressure_rate']):
        closed_loop = {'mode': 'position', 'max_pressure_rate': RAMP_RATE}
        assert all(r.successful for r in session.probe.set_parameters(controller, closed_loop))
        switched = time.monotonic()
        holding = commands.wait_for(lambda m: min(m.data) > HOLDING, START_TIMEOUT, since=switched)
        assert holding is not None, 'position mode never pressurised'
        killed = time.monotonic()
        assert session.kill('plant') == -9
        exited = time.time()  # the system clock of the send times
        zero = commands.wait_for(lambda m: max(m.data) == 0.0, START_TIMEOUT, since=killed)
        assert zero is not None, 'controller did not ramp down to zero without feedback'
        assert session.reported('pressure_command', killed + FEEDBACK_TIMEOUT)
        status = session.status('pressure_command', killed + FEEDBACK_TIMEOUT)
        assert status.level != b'\x00' and 'joint_states' in status.message, status.message
        assert session.alive('pressure_command') and session.alive('estimator')
        assert session.unsafe_commands(killed) == []
        # Once its feedback is stale, the controller only ever lowers the pressure. The plant
        # sent its last state before it died; the controller takes a state up to
        # FEEDBACK_TIMEOUT after its stamp (older ones it refuses) and it stays fresh for
        # FEEDBACK_TIMEOUT after it arrived. (A fresh-clone run found a bound from the last
        # state the probe heard plus 0.1 s delivery too early: the probe may miss the last
        # states, and a state may arrive later than that.)
        stale = exited + 2 * FEEDBACK_TIMEOUT + 2 / RATE
        peaks = [
            max(m.data)
            for _, m, info in commands.records()
            if info['source_timestamp'] > stale * 1e9
        ]
        assert peaks and peaks[0] > 0.0, 'the ramp was over before the feedback was surely stale'
        assert all(b <= a + 1e-9 for a, b in itertools.pairwise(peaks)), 'rose without feedback'
    restart_and_recover(session, 'plant')


def test_controller_killed_plant_vents_on_its_watchdog_then_recovers(session):
    killed = time.monotonic()
    assert session.kill('pressure_command') == -9
    vent_by = COMMAND_TIMEOUT + 0.5
    vented = session.inbox['chamber_pressure'].wait_for(
        lambda m: max(m.data) < VENTED, timeout=vent_by + START_TIMEOUT, since=killed
    )
    assert vented is not None, 'chambers did not vent'

    def venting_reported():
        status = session.status('plant', killed)
        values = {} if status is None else {kv.key: kv.value for kv in status.values}
        return values.get('watchdog') == 'venting' and 'watchdog' in status.message

    assert wait_until(venting_reported, COMMAND_TIMEOUT + 2 * REPORT_PERIOD), 'no venting report'

    assert session.alive('plant') and session.alive('estimator')
    restart_and_recover(session, 'pressure_command')


def test_estimator_killed_others_carry_on_and_it_resumes_within_one_window(session):
    killed = time.monotonic()
    assert session.kill('estimator') == -9
    # Plant and controller still publish WATCH s after the kill.
    assert session.flowing('joint_states', killed + WATCH, count=1)
    assert session.flowing('pressure_command', killed + WATCH, count=1)
    assert session.alive('plant') and session.alive('pressure_command')
    restarted = time.monotonic()
    session.start('estimator')
    first = session.inbox['estimated_contact_forces'].wait_for(
        lambda m: True, timeout=START_TIMEOUT, since=restarted
    )
    assert first is not None, 'estimator did not resume its force estimates'
    resumed = time.monotonic()
    stiffness = session.inbox['estimated_finger_stiffness']
    identified = stiffness.wait_for(lambda m: True, timeout=START_TIMEOUT, since=resumed)
    assert identified is not None, 'estimator did not resume its stiffness estimates'
    # Counted in plant steps, not seconds: a loaded machine slows the plant, not the rule.
    arrived = next(t for t, m, _ in stiffness.records() if m is identified)
    steps = len(
        [t for t, _, _ in session.inbox['joint_states'].records() if resumed < t <= arrived]
    )
    one_window = WINDOW + math.ceil(IDENTIFICATION_PERIOD * RATE) + DELIVERY_SLACK
    assert steps <= one_window, f'stiffness after {steps} plant steps, not within one window'
    assert session.normal(since=restarted) == []
