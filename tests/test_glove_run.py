"""The glove command as a user runs it: real node processes over DDS, the summary, the record.

Each test runs ``python -m exodigit_nodes.glove`` in its own namespace and ROS domain and checks
what it printed and wrote against the model computed here, independently of the nodes.
"""

import csv
import os
import signal
import struct
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
from exodigit_nodes.glove import DEFAULT_PATIENT
from ros_harness import ros_environment, wait_until
from rosbags.rosbag2 import Reader
from rosbags.typesys import Stores, get_typestore

from exodigit_model import GloveModel, load_params, patient_file

GLOVE = [sys.executable, '-m', 'exodigit_nodes.glove']
JOINTS = ('mcp', 'pip', 'dip')
#: Angles in the record against GloveModel.solve of the recorded chamber pressures, rad.
ANGLE_TOLERANCE = 1e-6
#: Forces in the record against the same solve, N.
FORCE_TOLERANCE = 1e-6
#: A model parameter file: the default glove on a finger twice as stiff.
STIFF_FINGER = """finger:
  joints:
    - {name: mcp, link_half_length: 0.023, stiffness: 0.080}
    - {name: pip, link_half_length: 0.0135, stiffness: 0.060}
    - {name: dip, link_half_length: 0.009, stiffness: 0.030}
"""
#: pressure_command's default hold pressure, kPa (config/pressure_command.yaml).
HOLD_PRESSURE_KPA = 20.0
#: Relative tolerance of the identified finger stiffness on noise-free data.
STIFFNESS_TOLERANCE = 1e-3
#: Seconds the glove may take to exit after the end of its duration or a SIGINT.
STOP_TIMEOUT = 15.0
#: Seconds to wait for the nodes to start and the first samples to arrive.
START_TIMEOUT = 60.0
#: Recorded steps before the SIGINT test stops a recording glove (4 s at 100 Hz): longer than
#: Fast DDS's 3 s heartbeat period, after which a reader that joined late or missed a message
#: (the recorder, on a loaded machine) has been repaired and receives the plant's steps.
BAG_ROWS = 400
SUPPLY_LIMIT = 200e3  # Pa, plant default max_supply_pressure upper bound used as a sanity limit


def namespace(tag):
    return f'/glove_test_{os.getpid()}_{tag}'


def node_pids(ns):
    """Live processes started with ``-r __ns:=<ns>`` (the glove's nodes)."""
    pids = []
    for proc in Path('/proc').iterdir():
        try:
            cmdline = (proc / 'cmdline').read_bytes().split(b'\0')
            state = (proc / 'stat').read_text().rsplit(')', 1)[1].split()[0]
        except (FileNotFoundError, ProcessLookupError, PermissionError, NotADirectoryError):
            continue
        if f'__ns:={ns}'.encode() in cmdline and state != 'Z':
            pids.append(int(proc.name))
    return pids


def read_record(path):
    """The run-record CSV as float columns (stdlib csv; empty cells as NaN)."""
    with open(path, newline='') as file:
        rows = list(csv.DictReader(file))
    return {key: np.array([float(r[key]) if r[key] else np.nan for r in rows]) for key in rows[0]}


def joint_columns(table, stem, unit):
    return np.stack([table[f'{stem}_{joint}_{unit}'] for joint in JOINTS], axis=1)


def png_size(path):
    data = path.read_bytes()
    assert data[:8] == b'\x89PNG\r\n\x1a\n' and data[12:16] == b'IHDR'
    return struct.unpack('>II', data[16:24])


def summary_angles(stdout):
    """Angles (deg) of every printed summary line that has them."""
    angles = []
    for line in stdout.splitlines():
        if 'q_deg=[' in line:
            cells = line.split('q_deg=[', 1)[1].split(']', 1)[0].split()
            if '-' not in cells:
                angles.append([float(c) for c in cells])
    return np.array(angles)


def pressurised_rows(path):
    """Rows of a run record so far with a positive pressure command and chamber pressure."""
    try:
        with open(path, newline='') as file:
            reader = csv.DictReader(file)
            if reader.fieldnames is None:
                return 0  # created, its header not written yet
            return sum(
                float(row['p_cmd_mcp_kpa'] or 0) > 0 and float(row['p_mcp_kpa']) > 0
                for row in reader
            )
    except (FileNotFoundError, ValueError):
        return 0  # not created yet, or a row being written


def test_a_timed_session_exits_0_and_records_what_the_model_predicts(ros_env, tmp_path):
    ns = namespace('timed')
    out = tmp_path / 'run'
    result = subprocess.run(
        [*GLOVE, '--duration', '8', '--namespace', ns, '--out', str(out)],
        env=ros_env,
        cwd=tmp_path,
        capture_output=True,
        text=True,
        timeout=8 + START_TIMEOUT + STOP_TIMEOUT,
    )
    assert result.returncode == 0, result.stdout[-2000:] + result.stderr[-2000:]
    assert f'ROS_DOMAIN_ID={ros_env["ROS_DOMAIN_ID"]}' in result.stdout
    assert str(out / 'signals.csv') in result.stdout

    printed = summary_angles(result.stdout)
    assert len(printed) >= 2, result.stdout
    assert np.ptp(printed, axis=0).max() > 0.5, 'the summary angles did not change'
    last_line = [line for line in result.stdout.splitlines() if 'q_deg=[' in line][-1]
    for node in ('plant', 'estimator', 'pressure_command'):
        assert f'{node} OK' in last_line or f'{node} WARN' in last_line, last_line

    table = read_record(out / 'signals.csv')
    pressure = 1e3 * joint_columns(table, 'p', 'kpa')
    angles = np.radians(joint_columns(table, 'q', 'deg'))
    forces = joint_columns(table, 'f', 'n')
    assert len(pressure) >= 100
    assert np.isfinite(pressure).all() and np.isfinite(angles).all()
    assert np.isfinite(forces).all()
    assert (pressure >= 0).all() and (pressure <= SUPPLY_LIMIT).all()
    assert np.ptp(pressure[:, 0]) > 5e3, 'the sine session did not move the chambers'
    assert np.all(np.diff(table['time_s']) > 0)

    # The default session simulates stroke_moderate (damped, spastic): each recorded step is
    # the stepped solve (docs/spec/model.md (11.4)) from the step before it, at its recorded
    # pressure.
    patient = GloveModel(load_params(patient_file(DEFAULT_PATIENT)))
    # (wall clock: stamps are the node clock, steps 10 ms of model time; a gap is a lost row)
    consecutive = np.flatnonzero(np.diff(table['time_s']) < 0.015)
    assert len(consecutive) >= 100
    for row in consecutive:
        expected = patient.solve(pressure[row + 1], q_previous=angles[row], dt=0.01)
        np.testing.assert_allclose(angles[row + 1], expected.q, rtol=0, atol=ANGLE_TOLERANCE)
        np.testing.assert_allclose(forces[row + 1], expected.forces, atol=FORCE_TOLERANCE)
    estimated = joint_columns(table, 'f_est', 'n')
    assert np.isfinite(estimated[~np.isnan(estimated)]).all()
    assert (~np.isnan(estimated)).any(), 'no estimated force was recorded'
    # the estimator, which assumes the nominal finger, identifies the patient instead
    nominal = load_params().finger.joints
    for stem, unit, key, scale in (
        ('k_est', 'nm_per_rad', 'stiffness', 1.0),
        ('qr_est', 'deg', 'rest_angle', 180.0 / np.pi),
    ):
        identified = joint_columns(table, stem, unit)[-1]
        truth = scale * np.array([getattr(j, key) for j in patient.params.finger.joints])
        assumed = scale * np.array([getattr(j, key) for j in nominal])
        assert (np.abs(identified - truth) < 0.5 * np.abs(assumed - truth)).all(), identified

    width, height = png_size(out / 'signals.png')
    assert width >= 400 and height >= 400
    assert (out / 'logs' / 'plant.log').is_file()
    assert node_pids(ns) == []


def bag_messages(path, topic):
    """The messages of one topic in a rosbag2 bag, read with rosbags."""
    typestore = get_typestore(Stores.ROS2_JAZZY)
    with Reader(path) as reader:
        connections = [c for c in reader.connections if c.topic == topic]
        return [
            typestore.deserialize_cdr(raw, connection.msgtype)
            for connection, _, raw in reader.messages(connections=connections)
        ]


def test_sigint_stops_every_node_with_zero_pressure_sent_first_and_recorded(ros_env, tmp_path):
    # Also passes a model file (a stiffer finger) and a mode to the nodes.
    ns = namespace('sigint')
    out = tmp_path / 'run'
    params_file = tmp_path / 'stiff_finger.yaml'
    params_file.write_text(STIFF_FINGER)
    arguments = ['--mode', 'hold', '--params-file', str(params_file), '--patient', 'nominal']
    arguments.append('--record')
    with open(tmp_path / 'stdout.txt', 'w') as stdout:
        glove = subprocess.Popen(
            [*GLOVE, '--namespace', ns, '--out', str(out), *arguments],
            env=ros_env,
            cwd=tmp_path,
            stdout=stdout,
            stderr=subprocess.PIPE,
            text=True,
        )
        try:
            record = out / 'signals.csv'
            settled = wait_until(lambda: pressurised_rows(record) >= BAG_ROWS, START_TIMEOUT)
            assert settled, (tmp_path / 'stdout.txt').read_text()[-2000:]
            assert len(node_pids(ns)) == 4  # three nodes and the recorder
            glove.send_signal(signal.SIGINT)
            interrupted = time.monotonic()
            _, stderr = glove.communicate(timeout=STOP_TIMEOUT)
            stop_time = time.monotonic() - interrupted
        finally:
            if glove.poll() is None:
                glove.kill()
    assert glove.returncode == 0, stderr
    assert stop_time < 10.0
    assert node_pids(ns) == []
    printed = (tmp_path / 'stdout.txt').read_text()
    assert 'stopping (SIGINT)' in printed
    table = read_record(out / 'signals.csv')
    command = joint_columns(table, 'p_cmd', 'kpa')
    # pressure_command stops first and publishes zero; the plant still runs and is recorded
    assert np.all(command[-1] == 0.0), command[-5:]
    assert np.nanmax(command) == pytest.approx(HOLD_PRESSURE_KPA)  # --mode hold reached it
    model = GloveModel(load_params(params_file))
    pressure = 1e3 * joint_columns(table, 'p', 'kpa')
    angles = np.radians(joint_columns(table, 'q', 'deg'))
    solved = model.solve_batch(pressure).q
    np.testing.assert_allclose(angles, solved, rtol=0, atol=ANGLE_TOLERANCE)
    default = GloveModel(load_params()).solve_batch(pressure).q
    assert np.abs(default - angles).max() > 100 * ANGLE_TOLERANCE  # the file was used
    # the recorder stops last: its bag ends with the zero command too
    recorded = bag_messages(out / 'bag', f'{ns}/pressure_command')
    assert any(np.any(message.data > 0.0) for message in recorded)
    assert np.all(recorded[-1].data == 0.0)
    assert len(bag_messages(out / 'bag', f'{ns}/joint_states')) >= 20


def test_ctrl_c_while_the_nodes_start_is_a_clean_stop_even_from_a_background_shell(
    ros_env, tmp_path
):
    # A shell starts background jobs with SIGINT ignored; the glove still takes Ctrl-C (kill
    # -INT), and nodes interrupted while still importing count as stopped, not failed.
    ns = namespace('early')
    out = tmp_path / 'run'
    glove = subprocess.Popen(
        [*GLOVE, '--namespace', ns, '--out', str(out)],
        env=ros_env,
        cwd=tmp_path,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_IGN),
    )
    try:
        assert wait_until(lambda: len(node_pids(ns)) == 3, START_TIMEOUT)
        glove.send_signal(signal.SIGINT)
        stdout, stderr = glove.communicate(timeout=STOP_TIMEOUT)
    finally:
        if glove.poll() is None:
            glove.kill()
    assert glove.returncode == 0, stdout + stderr
    assert 'stopping (SIGINT)' in stdout and 'Traceback' not in stdout + stderr
    assert node_pids(ns) == []


@pytest.mark.parametrize(
    ('arguments', 'environment', 'culprit'),
    [
        (['--params-file', '{bad_yaml}'], {}, 'material.c1'),
        (['--params-file', '{tmp}/missing.yaml'], {}, 'missing.yaml'),
        (['--ros-params', '{tmp}/missing.yaml'], {}, '--ros-params'),
        (['--duration', '-1'], {}, '--duration'),
        (['--namespace', 'glove'], {}, '--namespace'),
        ([], {'ROS_AUTOMATIC_DISCOVERY_RANGE': 'LAN'}, 'ROS_AUTOMATIC_DISCOVERY_RANGE'),
        ([], {'ROS_DOMAIN_ID': '500'}, 'ROS_DOMAIN_ID'),
        (['--out', '{bad_yaml}/run'], {}, 'run record'),
    ],
)
def test_bad_input_stops_the_glove_with_one_line_before_anything_starts(
    ros_env, tmp_path, arguments, environment, culprit
):
    bad_yaml = tmp_path / 'bad.yaml'
    bad_yaml.write_text('material:\n  c1: -5.0\n')
    out = tmp_path / 'run'
    arguments = [a.format(bad_yaml=bad_yaml, tmp=tmp_path) for a in arguments]
    result = subprocess.run(
        [*GLOVE, '--out', str(out), *arguments],
        env={**ros_env, **environment},
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert result.returncode == 2
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1, result.stderr
    assert lines[0].startswith('glove: ') and culprit in lines[0]
    assert 'Traceback' not in result.stderr
    assert not out.exists()


def test_a_node_that_dies_is_named_with_its_exit_code_and_the_glove_fails(ros_env, tmp_path):
    ns = namespace('dies')
    ros_params = tmp_path / 'ros_params.yaml'
    ros_params.write_text(f'{ns}/plant:\n  ros__parameters:\n    rate_hz: -5.0\n')
    result = subprocess.run(
        [
            *GLOVE,
            '--namespace',
            ns,
            '--out',
            str(tmp_path / 'run'),
            '--ros-params',
            str(ros_params),
        ],
        env=ros_env,
        capture_output=True,
        text=True,
        timeout=START_TIMEOUT + STOP_TIMEOUT,
    )
    assert result.returncode == 1, result.stdout + result.stderr
    assert 'glove: plant exited with code 2' in result.stderr
    assert 'rate_hz' in result.stderr  # the plant's own one-line reason, from its log
    assert 'Traceback' not in result.stderr
    assert node_pids(ns) == []


@pytest.fixture
def ros_env(ros_domain):
    """The environment a user's shell would have: the session's domain, loopback discovery."""
    return ros_environment(ros_domain)


def test_a_lockstep_session_records_each_step_of_its_simulated_duration_the_same_every_time(
    ros_env, tmp_path
):
    tables = []
    for run in ('first', 'second'):
        out = tmp_path / run
        args = ['--clock', 'sim', '--lockstep', '--real-time-factor', '0', '--duration', '3']
        result = subprocess.run(
            [*GLOVE, *args, '--namespace', namespace(f'sim_{run}'), '--out', str(out)],
            env=ros_env,
            cwd=tmp_path,
            capture_output=True,
            text=True,
            timeout=START_TIMEOUT + 3 * STOP_TIMEOUT,
        )
        assert result.returncode == 0, result.stdout[-2000:] + result.stderr[-2000:]
        assert 'stopping (3 simulated s elapsed)' in result.stdout
        tables.append(read_record(out / 'signals.csv'))
    for table in tables:
        # steps 1..300: t_k = k * 10 ms, the first row at 0 (time since the first step)
        np.testing.assert_allclose(table['time_s'], 0.01 * np.arange(300), atol=1e-9)
    for stem, unit in (('p', 'kpa'), ('q', 'deg'), ('f', 'n')):
        np.testing.assert_array_equal(
            joint_columns(tables[0], stem, unit), joint_columns(tables[1], stem, unit)
        )
    pressure = 1e3 * joint_columns(tables[0], 'p', 'kpa')
    assert np.ptp(pressure[:, 0]) > 5e3, 'the sine session did not move the chambers'


def test_lockstep_without_simulated_time_is_refused_before_anything_starts(ros_env, tmp_path):
    result = subprocess.run(
        [*GLOVE, '--lockstep', '--namespace', namespace('refused')],
        env=ros_env,
        cwd=tmp_path,
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert result.returncode == 2
    assert result.stderr.strip() == 'glove: --lockstep and --real-time-factor need --clock sim'
