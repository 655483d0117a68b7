"""The hand command as a user runs it: ``python -m exodigit_nodes.hand``, summary and records.

A lockstep session of two fingers for one simulated second: every finger's record has exactly
one row per step and its angles are what an in-process stepper of that finger's own model file
gives for the recorded commands (an independent replay, not the node's code path over DDS).
"""

import csv
import signal
import subprocess
import sys

import numpy as np
import pytest
from exodigit_nodes.hand_config import hand_config_dir
from ros_harness import ros_environment, wait_until

from exodigit_model import GloveModel, load_params

HAND = [sys.executable, '-m', 'exodigit_nodes.hand']
FINGERS = ('middle', 'thumb')
JOINTS = ('mcp', 'pip', 'dip')
RATE = 100.0
#: Recorded angles (12 significant digits) against the solve of the recorded pressures, rad.
ANGLE_TOLERANCE = 1e-9
#: Seconds for a session to start, run and stop.
TIMEOUT = 120.0


def read_record(path):
    with open(path, newline='') as file:
        rows = list(csv.DictReader(file))
    return {key: np.array([float(r[key]) if r[key] else np.nan for r in rows]) for key in rows[0]}


def estimated_rows(path) -> int:
    """Rows of a record being written that carry the estimated forces (complete lines only)."""
    if not path.is_file():
        return 0
    lines = [line for line in path.read_text().splitlines(keepends=True) if line.endswith('\n')]
    return sum(all(row[f'f_est_{j}_n'] for j in JOINTS) for row in csv.DictReader(lines))


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


def test_a_timed_lockstep_hand_records_every_step_of_every_finger(ros_domain, tmp_path):
    out = tmp_path / 'run'
    result = run_hand(
        ros_domain,
        tmp_path,
        *('--fingers', ','.join(FINGERS), '--clock', 'sim', '--lockstep'),
        *('--real-time-factor', '0', '--duration', '1', '--out', str(out)),
    )
    assert result.returncode == 0, result.stderr
    for finger in FINGERS:
        path = out / finger / 'signals.csv'
        assert f'run record: {path} ({round(RATE)} samples)' in result.stdout
        table = read_record(path)
        np.testing.assert_allclose(table['time_s'], np.arange(round(RATE)) / RATE, atol=1e-12)
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


def test_sigint_stops_the_hand_cleanly_with_its_records(ros_domain, tmp_path):
    out = tmp_path / 'run'
    process = subprocess.Popen(
        [*HAND, '--namespace', f'/hand_{ros_domain}', '--fingers', 'index', '--out', str(out)],
        cwd=tmp_path,
        env=ros_environment(ros_domain),
        stdin=subprocess.DEVNULL,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    record = out / 'index' / 'signals.csv'
    try:
        # the estimators start in a process of their own: wait for their first estimate too
        assert wait_until(lambda: estimated_rows(record) > 0, TIMEOUT)
    finally:
        process.send_signal(signal.SIGINT)
        stdout, stderr = process.communicate(timeout=TIMEOUT)
    assert process.returncode == 0, stderr
    assert 'stopping (SIGINT)' in stdout
    assert 'Traceback' not in stderr
    log = (out / 'logs' / 'hand_nodes.log').read_text()
    assert 'sent zero pressure' in log
    # the estimators run in a process of their own, and their estimates reached the record
    assert '.index.estimator]' in (out / 'logs' / 'hand_estimators.log').read_text()
    assert '.index.estimator]' not in log
    assert np.isfinite(columns(read_record(record), 'f_est', 'n')).all(axis=1).any()


@pytest.mark.parametrize(
    ('arguments', 'message'),
    [
        (['--fingers', 'pinky'], 'hand: --fingers pinky: give distinct names from thumb,'),
        (['--duration', '-1'], 'hand: --duration -1.0: must be a finite number of seconds'),
        (['--clock', 'sim', '--real-time-factor', '-2'], 'hand: --real-time-factor -2: '),
        (['--patient', 'nobody.yaml'], 'hand: --patient: '),
    ],
)
def test_a_refused_hand_starts_nothing_and_says_why(ros_domain, tmp_path, arguments, message):
    result = run_hand(ros_domain, tmp_path, *arguments, timeout=30.0)
    assert result.returncode == 2
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith(message), lines
    assert not (tmp_path / 'runs').exists()
