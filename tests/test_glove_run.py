"""The glove command as a user runs it: real node processes over DDS, the summary, the record.

Every session runs ``python -m exodigit_nodes.glove`` in a namespace and a ROS domain of its own.
The module fixture starts the sessions the selected tests ask for, three at a time (on two
cores), each watched (and, where its test says, interrupted) by a thread; several tests read
different aspects of one session, and check what it printed and wrote against the model
computed here, independently of the nodes. The refusals of bad input are one ``main`` call each,
in this process; one refusal runs as the command, for its exit status and its line on stderr.
"""

import csv
import os
import signal
import subprocess
import sys
from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pytest
from exodigit_model.tools.bag import read_bag
from exodigit_nodes.glove import main as glove_main
from exodigit_nodes.nodes.catalog import NODES as NODE_ENTRIES
from exodigit_nodes.nodes.hand_config import DEFAULT_PATIENTS
from png_files import png_size
from ros_harness import claim_domain, ros_environment, wait_until
from rosbags.rosbag2 import Reader
from rosbags.typesys import Stores, get_typestore

from exodigit_model import GloveModel, load_params, patient_file

GLOVE = [sys.executable, '-m', 'exodigit_nodes.glove']
NODES = tuple(entry.executable for entry in NODE_ENTRIES)
DEFAULT_PATIENT = DEFAULT_PATIENTS['glove']
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
#: Seconds the glove may take to exit after the end of its duration or a SIGINT.
STOP_TIMEOUT = 15.0
#: Seconds to wait for the nodes to start and the first samples to arrive.
START_TIMEOUT = 60.0
#: Recorded steps (2 s at 100 Hz) after which the SIGINT session waits for the estimator's next
#: fit (it fits once a second), then stops: that fit is over at least two seconds of the sine
#: session. By then the recorder, a reader that may have joined late or missed a message on a
#: loaded machine, has long been repaired (the package's Fast DDS profile sends a heartbeat
#: every 50 ms).
FIT_ROWS = 200
#: Consecutive recorded steps (no row lost between them) the wall-clock record must have.
CONSECUTIVE_ROWS = 100
#: Seconds of the wall-clock session: the node processes take longer to import and start.
WALL_DURATION = 0.5
#: A shell starting a background job: SIGINT ignored, which stays so across exec.
BACKGROUND = ('sh', '-c', 'trap "" INT; exec "$@"', 'sh')
SUPPLY_LIMIT = 200e3  # Pa, plant default max_supply_pressure upper bound used as a sanity limit
#: The nodes of a glove on a board: the hardware bridge in the plant's place.
BOARD_NODES = ('hardware', 'estimator', 'pressure_command')
#: Recorded steps at the hold pressure after which the emulated-board session is stopped.
HOLD_ROWS = 50
#: kPa: the valve loop's hold deadband (0.3) and the emulated pressure sensor's quantum (0.05).
BOARD_HOLD_KPA = 0.35
#: Simulated seconds of a lockstep session: the hold ramp and the chambers' lag, and a while
#: at the hold pressure.
LOCKSTEP_DURATION = 1


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


def assert_each_step_has_a_command_and_an_estimate(table, stem, unit):
    """Every row of a lockstep record holds a command (``stem``: its column) and an estimate.

    The runner resumes the plant only once every node has matched the summary's readers (a
    CI run's valves session recorded a command in none of its 100 rows), and the estimator keeps
    every state it is behind on in simulated time (with 10, 20-26 % of a run's rows had no
    estimate). A row's command is what the plant applied in that step (its applied_command,
    which starts with the vent the plant applies before the first answer): every row has one.
    """
    assert_every_row_has_a_command(table, stem, unit)
    estimated = np.isfinite(joint_columns(table, 'f_est', 'n')).all(axis=1)
    assert estimated.all(), f'rows without an estimate: {np.flatnonzero(~estimated)}'


def assert_every_row_has_a_command(table, stem, unit):
    """Each row of a record holds the command that drove its step (``stem``: its column)."""
    commanded = ~np.isnan(joint_columns(table, stem, unit)).any(axis=1)
    assert commanded.all(), f'rows without a command: {np.flatnonzero(~commanded)}'


def recorded_rows(path):
    """The whole rows of a run record being written (none before its header)."""
    try:
        with open(path, newline='') as file:
            return list(csv.DictReader([line for line in file if line.endswith('\n')]))
    except FileNotFoundError:
        return []


def fitted_after(path, steps):
    """Whether the record has an identification published after its first ``steps`` rows."""
    rows = recorded_rows(path)
    if len(rows) <= steps:
        return False
    latest = rows[-1]['k_est_mcp_nm_per_rad']
    return latest != '' and latest != rows[steps - 1]['k_est_mcp_nm_per_rad']


def printed(line, column):
    """The three cells of one signal in a summary line, as printed (``-`` before a value)."""
    return line.split(f' {column}=[', 1)[1].split(']', 1)[0].split()


def healthy_summary_line(stdout, nodes=NODES):
    """The last complete summary line under pressure with every node OK or WARN, else None."""
    lines = [line for line in stdout.splitlines(keepends=True) if line.endswith('\n')]
    for line in reversed(lines):
        if (
            line.startswith('t=')
            and all(cell not in ('-', '0.00') for cell in printed(line, 'p_kpa'))
            and all(f'{node} OK' in line or f'{node} WARN' in line for node in nodes)
        ):
            return line
    return None


def bag_messages(path, topic):
    """The messages of one topic in a rosbag2 bag, read with rosbags."""
    typestore = get_typestore(Stores.ROS2_JAZZY)
    with Reader(path) as reader:
        connections = [c for c in reader.connections if c.topic == topic]
        return [
            typestore.deserialize_cdr(raw, connection.msgtype)
            for connection, _, raw in reader.messages(connections=connections)
        ]


# -- the sessions ------------------------------------------------------------------------------


@dataclass
class Run:
    """One glove session of the module: where it ran, how it ended, what was seen meanwhile."""

    ns: str
    domain: int
    workdir: Path
    returncode: int | None = None
    seen: dict = field(default_factory=dict)

    @property
    def out(self) -> Path:
        return self.workdir / 'run'

    @property
    def stdout(self) -> str:
        return (self.workdir / 'stdout.txt').read_text()

    @property
    def stderr(self) -> str:
        return (self.workdir / 'stderr.txt').read_text()

    def output(self) -> str:
        """The ends of both streams and of the plant's log, for a failure message."""
        plant_log = self.out / 'logs' / 'plant.log'
        log = plant_log.read_text()[-1500:] if plant_log.is_file() else ''
        return f'{self.stdout[-2000:]}\n{self.stderr[-2000:]}\n{log}'


def launch(run: Run, arguments: list[str], prefix: tuple = ()) -> subprocess.Popen:
    """Start the glove of ``run`` (output to files in its workdir, read while it runs)."""
    command = [*prefix, *GLOVE, '--namespace', run.ns, '--out', str(run.out), *arguments]
    with (
        open(run.workdir / 'stdout.txt', 'w') as stdout,
        open(run.workdir / 'stderr.txt', 'w') as stderr,
    ):
        return subprocess.Popen(
            command,
            env=ros_environment(run.domain),
            cwd=run.workdir,
            stdin=subprocess.DEVNULL,
            stdout=stdout,
            stderr=stderr,
        )


def finish(run: Run, process: subprocess.Popen, timeout: float) -> Run:
    """Wait for the glove to exit by itself (killed after ``timeout``: returncode None)."""
    try:
        process.wait(timeout)
    except subprocess.TimeoutExpired:
        process.kill()
        process.wait()
        return run  # returncode None fails every test of it, with its output
    run.returncode = process.returncode
    return run


def ends_by_itself(arguments: Callable[[Run], list[str]]) -> Callable[[Run], Run]:
    """A session that runs until it exits by itself (duration, failure or refusal)."""

    def scenario(run: Run) -> Run:
        process = launch(run, arguments(run))
        return finish(run, process, START_TIMEOUT + STOP_TIMEOUT)

    return scenario


def lockstep_hold(run: Run) -> list[str]:
    """Simulated time in lockstep at full speed, hold mode, a model file (a stiffer finger)
    and the nominal patient (the file's finger)."""
    params_file = run.workdir / 'stiff_finger.yaml'
    params_file.write_text(STIFF_FINGER)
    return [
        *('--clock', 'sim', '--lockstep', '--real-time-factor', '0'),
        *('--duration', f'{LOCKSTEP_DURATION:g}', '--mode', 'hold'),
        *('--params-file', str(params_file), '--patient', 'nominal'),
    ]


def lockstep_hold_recorded(run: Run) -> list[str]:
    """:func:`lockstep_hold` with the session's topics also recorded to a bag."""
    return [*lockstep_hold(run), '--record']


def lockstep_hold_behind_valves(run: Run) -> list[str]:
    """:func:`lockstep_hold` with the plant behind valves and ``pressure_command`` a valve loop."""
    return [*lockstep_hold(run), '--actuation', 'valves']


def interrupted_once(arguments: list[str], settled: Callable[[Run], bool], prefix=()):
    """A session stopped by Ctrl-C (kill -INT) once ``settled(run)`` holds."""

    def scenario(run: Run) -> Run:
        process = launch(run, arguments, prefix=prefix)
        try:
            run.seen['settled'] = wait_until(lambda: settled(run), START_TIMEOUT, interval=0.1)
            run.seen['processes'] = len(node_pids(run.ns))  # while it still runs
            process.send_signal(signal.SIGINT)
            return finish(run, process, STOP_TIMEOUT)
        finally:
            if process.poll() is None:
                process.kill()
                process.wait()

    return scenario


def identified(run: Run) -> bool:
    """The record has a fit made after FIT_ROWS steps and the summary has shown every node's
    health."""
    return fitted_after(run.out / 'signals.csv', FIT_ROWS) and bool(
        healthy_summary_line(run.stdout)
    )


def holding_on_the_board(run: Run) -> bool:
    """The record's last HOLD_ROWS steps are at the hold pressure (within the valve loop's
    deadband and the emulated sensor's quantum) and the summary has shown the board's nodes'
    health."""
    rows = recorded_rows(run.out / 'signals.csv')[-HOLD_ROWS:]
    held = len(rows) == HOLD_ROWS and all(
        abs(float(row[f'p_{joint}_kpa']) - HOLD_PRESSURE_KPA) <= BOARD_HOLD_KPA
        for row in rows
        for joint in JOINTS
    )
    return held and bool(healthy_summary_line(run.stdout, BOARD_NODES))


def plant_fails(run: Run) -> list[str]:
    ros_params = run.workdir / 'ros_params.yaml'
    ros_params.write_text(f'{run.ns}/plant:\n  ros__parameters:\n    rate_hz: -5.0\n')
    return ['--ros-params', str(ros_params)]


#: The sessions, in start order: the longest first, PARALLEL at a time.
SCENARIOS = {
    # the default session on the wall clock, from a background shell, until Ctrl-C
    'interrupted_run': interrupted_once(['--record'], identified, prefix=BACKGROUND),
    # two identical lockstep sessions, for "the same every time"
    'lockstep_run': ends_by_itself(lockstep_hold),
    'lockstep_rerun': ends_by_itself(lockstep_hold_recorded),
    'valves_run': ends_by_itself(lockstep_hold_behind_valves),
    # make run HARDWARE=emulated: the bridge and the emulated board, until Ctrl-C (after the
    # longest three: five processes of its own)
    'emulated_run': interrupted_once(
        ['--hardware', 'emulated', '--mode', 'hold', '--patient', 'nominal'],
        holding_on_the_board,
    ),
    'failing_run': ends_by_itself(plant_fails),
    # the wall clock's duration, over while the nodes still start
    'wall_clock_run': ends_by_itself(lambda run: ['--duration', f'{WALL_DURATION:g}']),
    'refused_run': ends_by_itself(lambda run: ['--lockstep']),
}
#: Sessions running at once: a lockstep session keeps about one core busy, the others wait
#: for much of theirs (the wall clock, a stop); more would only contend on two cores, and
#: stretch the stops the supervisor gives a grace period.
PARALLEL = 3


@pytest.fixture(scope='module')
def sessions(request, tmp_path_factory):
    """The sessions of SCENARIOS that the selected tests of this module read, PARALLEL at a
    time, each in a ROS domain of its own (two sessions on simulated time would otherwise both
    drive /clock); name -> Future of its Run."""
    wanted = {
        name
        for item in request.session.items
        if item.module is request.module
        for name in item.fixturenames
        if name in SCENARIOS
    }
    leases = []
    try:
        with ThreadPoolExecutor(max_workers=PARALLEL) as pool:
            futures = {}
            for name, scenario in SCENARIOS.items():
                if name in wanted:
                    leases.append(claim_domain())
                    run = Run(namespace(name), leases[-1].domain_id, tmp_path_factory.mktemp(name))
                    futures[name] = pool.submit(scenario, run)
            yield futures
            # leaving the pool waits for every session: none outlives the module
    finally:
        for lease in leases:
            lease.release()


# One fixture per session, named as in SCENARIOS: what a test asks for is what gets started.


@pytest.fixture(scope='module')
def lockstep_run(sessions) -> Run:
    return sessions['lockstep_run'].result()


@pytest.fixture(scope='module')
def lockstep_rerun(sessions) -> Run:
    return sessions['lockstep_rerun'].result()


@pytest.fixture(scope='module')
def interrupted_run(sessions) -> Run:
    return sessions['interrupted_run'].result()


@pytest.fixture(scope='module')
def valves_run(sessions) -> Run:
    return sessions['valves_run'].result()


@pytest.fixture(scope='module')
def emulated_run(sessions) -> Run:
    return sessions['emulated_run'].result()


@pytest.fixture(scope='module')
def failing_run(sessions) -> Run:
    return sessions['failing_run'].result()


@pytest.fixture(scope='module')
def wall_clock_run(sessions) -> Run:
    return sessions['wall_clock_run'].result()


@pytest.fixture(scope='module')
def refused_run(sessions) -> Run:
    return sessions['refused_run'].result()


# -- lockstep sessions on simulated time ----------------------------------------------------


def test_a_timed_session_exits_0_and_says_where_its_record_plot_and_logs_are(lockstep_run):
    assert lockstep_run.returncode == 0, lockstep_run.output()
    assert f'ROS_DOMAIN_ID={lockstep_run.domain}' in lockstep_run.stdout
    assert f'stopping ({LOCKSTEP_DURATION:g} simulated s elapsed)' in lockstep_run.stdout
    record = lockstep_run.out / 'signals.csv'
    # a record short of steps: the whole output, with the runner's count of messages that
    # joined no step and the nodes' logs' paths
    assert (
        f'run record: {record} ({round(100 * LOCKSTEP_DURATION)} samples)' in lockstep_run.stdout
    ), lockstep_run.output()
    assert f'plot: {lockstep_run.out / "signals.png"}' in lockstep_run.stdout
    width, height = png_size(lockstep_run.out / 'signals.png')
    assert width >= 400 and height >= 400
    assert (lockstep_run.out / 'logs' / 'plant.log').is_file()
    assert node_pids(lockstep_run.ns) == []


def test_a_lockstep_session_records_each_step_of_its_simulated_duration_the_same_every_time(
    lockstep_run, lockstep_rerun
):
    tables = []
    for run in (lockstep_run, lockstep_rerun):
        assert run.returncode == 0, run.output()
        tables.append(read_record(run.out / 'signals.csv'))
        # steps 1..N: t_k = k * 10 ms, the first row at 0 (time since the first step)
        steps = np.arange(round(100 * LOCKSTEP_DURATION))
        np.testing.assert_allclose(
            tables[-1]['time_s'], 0.01 * steps, atol=1e-9, err_msg=run.output()
        )
    # run at the same time on a shared machine, in domains of their own, one of them
    # recording a bag: still identical
    for stem, unit in (('p', 'kpa'), ('q', 'deg'), ('f', 'n')):
        np.testing.assert_array_equal(
            joint_columns(tables[0], stem, unit), joint_columns(tables[1], stem, unit)
        )
    pressure = 1e3 * joint_columns(tables[0], 'p', 'kpa')
    assert np.ptp(pressure[:, 0]) > 5e3, 'the session did not move the chambers'


def test_a_recorded_lockstep_session_has_every_step_in_its_bag(lockstep_rerun):
    # At real-time factor 0 the plant outruns a recorder that subscribes late or falls behind:
    # the runner resumes the plant only once the recorder listens, and every publisher keeps
    # enough samples for it to catch up.
    assert lockstep_rerun.returncode == 0, lockstep_rerun.output()
    bag = read_bag(lockstep_rerun.out / 'bag')
    table = read_record(lockstep_rerun.out / 'signals.csv')
    steps = round(100 * LOCKSTEP_DURATION)
    for topic in ('joint_states', 'chamber_pressure', 'contact_forces'):
        assert len(bag[topic].values) == steps and bag[topic].skipped == 0, topic
    np.testing.assert_allclose(
        np.degrees(bag['joint_states'].values),
        joint_columns(table, 'q', 'deg'),
        atol=1e-9,
        err_msg=lockstep_rerun.output(),
    )


def test_a_session_behind_valves_fills_the_chambers_to_the_held_pressure(valves_run):
    # make run ACTUATION=valves: the plant takes openings, pressure_command's loop sends them.
    # The runner resumes the plant once the signals of its actuation are matched (it waited
    # forever for a pressure_command publisher that a valve session does not have).
    assert valves_run.returncode == 0, valves_run.output()
    table = read_record(valves_run.out / 'signals.csv')
    assert len(table['time_s']) == round(100 * LOCKSTEP_DURATION)
    assert_each_step_has_a_command_and_an_estimate(table, 'u_net', 'pct')
    openings = joint_columns(table, 'u_net', 'pct')
    assert np.nanmax(openings) > 0.0  # the inlets opened
    pressure = joint_columns(table, 'p', 'kpa')[-1]
    # the loop holds each chamber within its deadband (300 Pa) of the target, 1 s in
    np.testing.assert_allclose(pressure, HOLD_PRESSURE_KPA, atol=0.3)
    assert np.isnan(joint_columns(table, 'p_cmd', 'kpa')).all()  # no pressure is commanded


def test_the_nodes_run_the_given_mode_and_model_file(lockstep_run):
    assert lockstep_run.returncode == 0, lockstep_run.output()
    table = read_record(lockstep_run.out / 'signals.csv')
    assert_each_step_has_a_command_and_an_estimate(table, 'p_cmd', 'kpa')
    command = joint_columns(table, 'p_cmd', 'kpa')
    assert np.nanmax(command) == pytest.approx(HOLD_PRESSURE_KPA)  # --mode hold reached it
    # the nominal patient: each step is the equilibrium of the file's finger at its pressure
    model = GloveModel(load_params(lockstep_run.workdir / 'stiff_finger.yaml'))
    pressure = 1e3 * joint_columns(table, 'p', 'kpa')
    angles = np.radians(joint_columns(table, 'q', 'deg'))
    np.testing.assert_allclose(angles, model.solve_batch(pressure).q, rtol=0, atol=ANGLE_TOLERANCE)
    default = GloveModel(load_params()).solve_batch(pressure).q
    assert np.abs(default - angles).max() > 100 * ANGLE_TOLERANCE  # the file was used


# -- the default session on the wall clock, stopped by Ctrl-C -------------------------------


def test_sigint_stops_every_node_with_zero_pressure_sent_first_and_recorded(interrupted_run):
    # Started from a background shell, with SIGINT ignored: the glove still takes Ctrl-C.
    assert interrupted_run.seen['settled'], interrupted_run.output()
    assert interrupted_run.seen['processes'] == 4  # three nodes and the recorder
    assert interrupted_run.returncode == 0, interrupted_run.output()
    assert node_pids(interrupted_run.ns) == []
    assert 'stopping (SIGINT)' in interrupted_run.stdout
    assert 'Traceback' not in interrupted_run.stdout + interrupted_run.stderr
    table = read_record(interrupted_run.out / 'signals.csv')
    command = joint_columns(table, 'p_cmd', 'kpa')
    # pressure_command stops first and publishes zero; the plant still runs and is recorded
    assert np.all(command[-1] == 0.0), command[-5:]
    # the recorder stops last: its bag ends with the zero command too
    bag = interrupted_run.out / 'bag'
    recorded = bag_messages(bag, f'{interrupted_run.ns}/pressure_command')
    assert any(np.any(message.data > 0.0) for message in recorded)
    assert np.all(recorded[-1].data == 0.0)
    assert len(bag_messages(bag, f'{interrupted_run.ns}/joint_states')) >= 20
    width, height = png_size(interrupted_run.out / 'signals.png')
    assert width >= 400 and height >= 400


def test_a_wall_clock_record_has_the_command_of_every_row_from_the_first(interrupted_run):
    # make run's path: nothing holds a plant on the wall clock, and the summary's readers match
    # the plant's states before they match the controller (a fresh clone's record had no
    # command in its first 221 rows). The plant's record of its commands is kept for late
    # readers, the bag's too.
    assert interrupted_run.returncode == 0, interrupted_run.output()
    assert_every_row_has_a_command(
        read_record(interrupted_run.out / 'signals.csv'), 'p_cmd', 'kpa'
    )
    applied = bag_messages(interrupted_run.out / 'bag', f'{interrupted_run.ns}/applied_command')
    assert np.all(applied[0].data == 0.0)  # the vent the plant starts with, before any command
    assert any(np.any(message.data > 0.0) for message in applied)


def test_each_recorded_step_is_what_the_patient_model_predicts_from_the_step_before(
    interrupted_run,
):
    assert interrupted_run.seen['settled'], interrupted_run.output()
    table = read_record(interrupted_run.out / 'signals.csv')
    pressure = 1e3 * joint_columns(table, 'p', 'kpa')
    angles = np.radians(joint_columns(table, 'q', 'deg'))
    forces = joint_columns(table, 'f', 'n')
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
    assert len(consecutive) >= CONSECUTIVE_ROWS
    for row in consecutive:
        expected = patient.solve(pressure[row + 1], q_previous=angles[row], dt=0.01)
        np.testing.assert_allclose(angles[row + 1], expected.q, rtol=0, atol=ANGLE_TOLERANCE)
        np.testing.assert_allclose(forces[row + 1], expected.forces, atol=FORCE_TOLERANCE)


def test_the_estimator_identifies_the_simulated_patient_not_the_finger_it_assumes(
    interrupted_run,
):
    assert interrupted_run.seen['settled'], interrupted_run.output()
    table = read_record(interrupted_run.out / 'signals.csv')
    estimated = joint_columns(table, 'f_est', 'n')
    assert np.isfinite(estimated[~np.isnan(estimated)]).all()
    assert (~np.isnan(estimated)).any(), 'no estimated force was recorded'
    # the estimator, which assumes the nominal finger, identifies the patient instead: each
    # value nearer the patient's than the nominal finger's (a linear fit of a patient with
    # damping, spasticity and range-of-motion torques, over the two seconds or so of a wall
    # clock session on a busy machine: not more)
    patient = load_params(patient_file(DEFAULT_PATIENT)).finger.joints
    nominal = load_params().finger.joints
    for stem, unit, key, scale in (
        ('k_est', 'nm_per_rad', 'stiffness', 1.0),
        ('qr_est', 'deg', 'rest_angle', 180.0 / np.pi),
    ):
        identified = joint_columns(table, stem, unit)[-1]
        truth = scale * np.array([getattr(j, key) for j in patient])
        assumed = scale * np.array([getattr(j, key) for j in nominal])
        assert (np.abs(identified - truth) < np.abs(identified - assumed)).all(), identified


def test_the_summary_shows_the_recorded_angles_in_degrees_and_every_node_healthy(interrupted_run):
    assert interrupted_run.seen['settled'], interrupted_run.output()
    line = healthy_summary_line(interrupted_run.stdout)  # printed under pressure
    # its angles are a recorded step's (the latest received, which the record has too)
    table = read_record(interrupted_run.out / 'signals.csv')
    recorded = {tuple(f'{q:.2f}' for q in row) for row in joint_columns(table, 'q', 'deg')}
    assert tuple(printed(line, 'q_deg')) in recorded, line


# -- make run HARDWARE=emulated ----------------------------------------------------------------


def test_the_glove_runs_through_the_bridge_on_the_emulated_board(emulated_run):
    assert emulated_run.seen['settled'], emulated_run.output()
    assert emulated_run.seen['processes'] == 3  # the bridge, estimator, pressure_command
    assert emulated_run.returncode == 0, emulated_run.output()
    assert node_pids(emulated_run.ns) == []
    assert 'Traceback' not in emulated_run.stdout + emulated_run.stderr
    assert f'on the emulated board {emulated_run.out / "board"}' in emulated_run.stdout
    assert not (emulated_run.out / 'board').exists()  # the emulator took its pty away
    logs = sorted(log.stem for log in (emulated_run.out / 'logs').iterdir())
    assert logs == sorted([*BOARD_NODES, 'mcu_emulator'])
    assert 'vented and closed the port' in (emulated_run.out / 'logs' / 'hardware.log').read_text()


def test_the_board_glove_is_recorded_from_the_boards_samples(emulated_run):
    # the summary showed the board's pressures with the bridge healthy
    assert healthy_summary_line(emulated_run.stdout, BOARD_NODES), emulated_run.output()
    table = read_record(emulated_run.out / 'signals.csv')
    assert_every_row_has_a_command(table, 'u_net', 'pct')  # the openings the board applied
    assert np.isnan(joint_columns(table, 'f', 'n')).all()  # a board measures no contact force
    pressure = 1e3 * joint_columns(table, 'p', 'kpa')
    assert np.all(np.abs(pressure / 50.0 - np.round(pressure / 50.0)) < 1e-6)  # its sensor
    # each step's angles are the nominal finger's at its pressure (the emulated patient), within
    # the sensors' quanta (50 Pa of pressure, 1e-3 rad of angle)
    angles = np.radians(joint_columns(table, 'q', 'deg'))
    model = GloveModel(load_params()).solve_batch(pressure).q
    np.testing.assert_allclose(angles, model, rtol=0, atol=2e-3)


# -- the wall clock's duration, a failing node -------------------------------------------------


def test_a_wall_clock_duration_ends_the_glove_cleanly_even_while_the_nodes_start(wall_clock_run):
    # Nodes stopped while still importing or starting count as stopped, not failed.
    output = wall_clock_run.output()  # shown with any failure below (a rare one is unexplained)
    assert wall_clock_run.returncode == 0, output
    assert f'stopping ({WALL_DURATION:g} s elapsed)' in wall_clock_run.stdout, output
    # every node process had been started (the supervisor opens its log as it starts it)
    logs = sorted(log.stem for log in (wall_clock_run.out / 'logs').iterdir())
    assert logs == sorted(NODES), output
    assert 'Traceback' not in wall_clock_run.stdout + wall_clock_run.stderr, output
    assert node_pids(wall_clock_run.ns) == [], output


def test_a_node_that_dies_is_named_with_its_exit_code_and_the_glove_fails(failing_run):
    assert failing_run.returncode == 1, failing_run.output()
    assert 'glove: plant exited with code 2' in failing_run.stderr
    assert 'rate_hz' in failing_run.stderr  # the plant's own one-line reason, from its log
    assert 'Traceback' not in failing_run.stderr
    assert node_pids(failing_run.ns) == []


# -- refusals before anything starts -----------------------------------------------------------


def test_lockstep_without_simulated_time_is_refused_before_anything_starts(refused_run):
    # The command itself: exit status 2 and one line on stderr, nothing else printed.
    assert refused_run.returncode == 2, refused_run.output()
    assert (
        refused_run.stderr.strip() == 'glove: --lockstep and --real-time-factor need --clock sim'
    )
    assert not refused_run.out.exists()


@pytest.mark.parametrize(
    ('arguments', 'environment', 'culprit'),
    [
        (['--params-file', '{bad_yaml}'], {}, 'material.c1'),
        (['--params-file', '{tmp}/missing.yaml'], {}, 'missing.yaml'),
        (['--ros-params', '{tmp}/missing.yaml'], {}, '--ros-params'),
        (['--duration', '-1'], {}, '--duration'),
        (['--namespace', 'glove'], {}, '--namespace'),
        (['--clock', 'sim', '--real-time-factor', '-2'], {}, '--real-time-factor'),
        ([], {'ROS_AUTOMATIC_DISCOVERY_RANGE': 'LAN'}, 'ROS_AUTOMATIC_DISCOVERY_RANGE'),
        ([], {'ROS_DOMAIN_ID': '500'}, 'ROS_DOMAIN_ID'),
        (['--out', '{bad_yaml}/run'], {}, 'run record'),
    ],
)
def test_bad_input_stops_the_glove_with_one_line_before_anything_starts(
    tmp_path, monkeypatch, capsys, arguments, environment, culprit
):
    # The runner's main, in this process: it returns before starting a process or rclpy.
    monkeypatch.chdir(tmp_path)
    monkeypatch.setenv('ROS_AUTOMATIC_DISCOVERY_RANGE', 'LOCALHOST')  # put back afterwards:
    monkeypatch.setenv('ROS_DOMAIN_ID', '0')  # main exports the settings it reads
    for name, value in environment.items():
        monkeypatch.setenv(name, value)
    bad_yaml = tmp_path / 'bad.yaml'
    bad_yaml.write_text('material:\n  c1: -5.0\n')
    out = tmp_path / 'run'
    arguments = [a.format(bad_yaml=bad_yaml, tmp=tmp_path) for a in arguments]
    assert glove_main(['--out', str(out), *arguments]) == 2
    printed = capsys.readouterr()
    lines = printed.err.strip().splitlines()
    assert len(lines) == 1, printed.err
    assert lines[0].startswith('glove: ') and culprit in lines[0]
    assert printed.out == ''
    assert not out.exists()
    assert list(tmp_path.iterdir()) == [bad_yaml]  # no default runs/ directory either
