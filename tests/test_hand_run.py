"""The hand command as a user runs it: ``python -m exodigit_nodes.hand``, summary and records.

One session, read by the tests that need a running hand: two fingers in lockstep for one simulated
second. Every finger's record has exactly one row per step and its angles are what that finger's
own model file gives for the recorded pressures (an independent solve, not the node's code path
over DDS); the estimators run in the hand's one process beside the plants and, with the
controllers in ``force`` mode, their estimates reach the records; each finger has a bag of every
step (``--record``); at the stop every command node sends zero pressure.
Refusals of bad input are ``main`` calls in this process, and one run of the command for its exit
status."""

import csv
import subprocess
import sys

import numpy as np
import pytest
from exodigit_model.tools.bag import read_bag
from exodigit_nodes.hand import main as hand_main
from exodigit_nodes.nodes.hand_config import hand_config_dir
from ros_harness import ros_environment

from exodigit_model import GloveModel, load_params

HAND = [sys.executable, '-m', 'exodigit_nodes.hand']
FINGERS = ('middle', 'thumb')
JOINTS = ('mcp', 'pip', 'dip')
RATE = 100.0
#: Recorded angles (12 significant digits) against the solve of the recorded pressures, rad.
ANGLE_TOLERANCE = 1e-9
#: Recorded estimated forces (3 decimals) against an estimate of the recorded state, N.
ESTIMATE_DIGITS = 1e-3
#: Simulated seconds of the session.
DURATION = 1.0
#: Seconds for a session to start, run and stop.
TIMEOUT = 120.0


def read_record(path):
    with open(path, newline='') as file:
        rows = list(csv.DictReader(file))
    return {key: np.array([float(r[key]) if r[key] else np.nan for r in rows]) for key in rows[0]}


def columns(table, tag, unit):
    return np.column_stack([table[f'{tag}_{joint}_{unit}'] for joint in JOINTS])


def run_hand(ros_domain, tmp_path, *arguments, timeout=TIMEOUT):
    return subprocess.run(
        [*HAND, '--namespace', f'/hand_{ros_domain}', *arguments],
        cwd=tmp_path,
        env=ros_environment(ros_domain),
        stdin=subprocess.DEVNULL,
        capture_output=True,
        text=True,
        timeout=timeout,
        check=False,
    )


@pytest.fixture(scope='module')
def session(ros_domain, tmp_path_factory):
    """One recorded lockstep session of two fingers for DURATION simulated seconds, run to its end.

    In ``force`` mode each controller's answer waits for its step's estimate, so the estimators
    are in lockstep too (in the other modes they are not: at real-time factor 0 the plants can
    finish a short session before an estimator's first estimate arrives).
    """
    workdir = tmp_path_factory.mktemp('hand')
    result = run_hand(
        ros_domain,
        workdir,
        *('--fingers', ','.join(FINGERS), '--clock', 'sim', '--lockstep', '--mode', 'force'),
        '--record',
        *('--real-time-factor', '0', '--duration', f'{DURATION:g}', '--out', str(workdir / 'run')),
    )
    return result, workdir / 'run'


def test_a_timed_lockstep_hand_records_every_step_of_every_finger(session):
    result, out = session
    assert result.returncode == 0, result.stdout[-2000:] + result.stderr[-2000:]
    assert f'stopping ({DURATION:g} simulated s elapsed)' in result.stdout
    steps = round(DURATION * RATE)
    for finger in FINGERS:
        path = out / finger / 'signals.csv'
        assert f'run record: {path} ({steps} samples)' in result.stdout
        table = read_record(path)
        np.testing.assert_allclose(table['time_s'], np.arange(steps) / RATE, atol=1e-12)
        # each row's angles are the finger model's equilibrium at that row's chamber pressures
        model = GloveModel(load_params([hand_config_dir() / f'{finger}.yaml']))
        solved = model.solve_batch(columns(table, 'p', 'kpa') * 1e3)
        assert solved.converged.all()
        np.testing.assert_allclose(
            np.radians(columns(table, 'q', 'deg')), solved.q, rtol=0.0, atol=ANGLE_TOLERANCE
        )
        other = GloveModel(
            load_params([hand_config_dir() / f'{FINGERS[1 - FINGERS.index(finger)]}.yaml'])
        )
        assert (
            np.max(np.abs(other.solve_batch(columns(table, 'p', 'kpa') * 1e3).q - solved.q)) > 1e-4
        )
        assert (out / finger / 'signals.png').read_bytes()[:4] == b'\x89PNG'


def test_the_hand_stops_cleanly_with_zero_pressure_sent_and_the_estimates_recorded(session):
    result, out = session
    assert result.returncode == 0, result.stderr
    assert 'Traceback' not in result.stderr
    assert sorted(path.name for path in (out / 'logs').iterdir()) == [
        'hand_nodes.log',
        'recorder.log',
    ]
    log = (out / 'logs' / 'hand_nodes.log').read_text()
    assert log.count('sent zero pressure') == len(FINGERS)  # every finger's command node
    # the estimators run in the one process, and their estimates reached the records
    for finger in FINGERS:
        assert f'.{finger}.estimator]' in log
        table = read_record(out / finger / 'signals.csv')
        estimated = columns(table, 'f_est', 'n')
        rows = np.isfinite(estimated).all(axis=1)
        assert rows.any(), finger
        # each row's estimate is its own step's: the robot-side estimate at that row's angles
        # and pressures (needs no finger model), to the record's rounding
        model = GloveModel(load_params([hand_config_dir() / f'{finger}.yaml']))
        q, p = np.radians(columns(table, 'q', 'deg')), columns(table, 'p', 'kpa') * 1e3
        np.testing.assert_allclose(
            estimated[rows], model.estimate_forces_batch(q[rows], p[rows]), atol=ESTIMATE_DIGITS
        )


def test_record_gives_each_finger_a_bag_of_every_step(session):
    # One recorder, a bag per finger; the runner resumes the hand only once it listens.
    result, out = session
    assert result.returncode == 0, result.stderr
    steps = round(DURATION * RATE)
    for finger in FINGERS:
        bag = read_bag(out / 'bag' / finger)
        for topic in ('joint_states', 'chamber_pressure', 'contact_forces'):
            counts = {name: len(series.values) for name, series in bag.items()}
            # A failure shows the bag's counts and the nodes' logs (one beside busy cores had
            # no joint_states of a finger at all, and its logs were gone).
            logs = '\n'.join(
                f'--- {log.name}\n' + log.read_text()[-3000:]
                for log in sorted((out / 'logs').glob('*'))
                if log.is_file()
            )
            assert topic in bag and len(bag[topic].values) == steps, (finger, counts, logs)
            assert bag[topic].skipped == 0, (finger, topic)
        table = read_record(out / finger / 'signals.csv')
        np.testing.assert_allclose(
            np.degrees(bag['joint_states'].values), columns(table, 'q', 'deg'), atol=1e-9
        )


def test_a_refused_hand_command_exits_2_with_one_line_on_stderr(ros_domain, tmp_path):
    # The command itself (the other refusals: main in this process, below).
    result = run_hand(ros_domain, tmp_path, '--fingers', 'pinky', timeout=30.0)
    assert result.returncode == 2
    assert result.stderr.strip().splitlines() == [
        'hand: --fingers pinky: give distinct names from thumb,index,middle,ring,little'
    ]
    assert result.stdout == ''
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize(
    ('arguments', 'message'),
    [
        (['--fingers', 'pinky'], 'hand: --fingers pinky: give distinct names from thumb,'),
        (['--fingers', 'index,index'], 'hand: --fingers index,index: give distinct names'),
        (['--duration', '-1'], 'hand: --duration -1.0: must be a finite number of seconds'),
        (['--clock', 'sim', '--real-time-factor', '-2'], 'hand: --real-time-factor -2: '),
        (['--lockstep'], 'hand: --lockstep and --real-time-factor need --clock'),
        (['--namespace', 'hand'], "hand: --namespace 'hand': must be absolute"),
        (['--namespace', '/1hand'], "hand: --namespace '/1hand': must be absolute"),
        (['--patient', 'nobody.yaml'], 'hand: --patient: '),
        (['--ros-params', 'missing.yaml'], 'hand: --ros-params missing.yaml: no such file'),
    ],
)
def test_a_refused_hand_starts_nothing_and_says_why(
    tmp_path, monkeypatch, capsys, arguments, message
):
    # The runner's main, in this process: it returns before starting a process or rclpy.
    monkeypatch.chdir(tmp_path)
    assert hand_main(arguments) == 2
    printed = capsys.readouterr()
    lines = printed.err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith(message), lines
    assert printed.out == ''
    assert list(tmp_path.iterdir()) == []  # no runs/ directory
