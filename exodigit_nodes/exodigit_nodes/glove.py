"""Run the whole simulated glove from one command, with a live summary and a run record.

Starts ``plant``, ``estimator`` and ``pressure_command`` as separate processes in one namespace
(and the rosbag2 ``recorder`` with ``--record``), shows their signals on the terminal, writes
``signals.csv`` and ``signals.png`` into the run directory and stops everything on Ctrl-C or
after ``--duration`` seconds: the command node first, so the chambers get zero pressure.

With ``--clock sim`` the plant owns simulated time (``/clock``) and every other node runs with
``use_sim_time``; ``--real-time-factor`` paces it (0 = as fast as possible) and ``--lockstep``
keeps one step in flight, so a session gives the same result on a loaded machine as on an idle
one. ``--duration`` then counts simulated seconds.

This is what ``make run`` calls; on a ROS 2 install ``ros2 launch exodigit_nodes
glove.launch.py`` starts the same nodes without the summary.
"""

import argparse
import os
import re
import signal
import sys
import time
from pathlib import Path

from exodigit_model.params import PATIENT_PRESETS

from exodigit_nodes import catalog
from exodigit_nodes.controllers import MODES
from exodigit_nodes.pacing import MAX_REAL_TIME_FACTOR
from exodigit_nodes.ros_env import discovery_settings
from exodigit_nodes.run_record import RunRecord, new_run_directory
from exodigit_nodes.summary import SIGNALS, GloveSignals, SummaryDisplay
from exodigit_nodes.supervisor import Supervisor

#: The glove's node executables, in start order (the plant first, commands last).
NODES = tuple(node.executable for node in catalog.NODES)
#: Stop order: commands first (the node publishes zero pressure as it stops), recorder last.
STOP_ORDER = (*reversed(NODES), 'recorder')
#: The runner's defaults of the node parameters it has options for: the nodes' own.
MODE = catalog.PRESSURE_COMMAND_NODE.table['mode']
CLOCK = catalog.PLANT_NODE.table['clock']
REAL_TIME_FACTOR = catalog.PLANT_NODE.table['real_time_factor']
#: The finger the default session's plant simulates (the controller assumes the nominal one).
DEFAULT_PATIENT = 'stroke_moderate'
#: --patient value for "the glove file alone" (the nominal finger).
NOMINAL_PATIENT = 'nominal'
#: Seconds between two refreshes of the terminal summary.
REFRESH_PERIOD = 0.25
#: Lines of a dead node's log shown when it exits unexpectedly.
LOG_TAIL_LINES = 8
NAMESPACE_PATTERN = re.compile(r'^(/[A-Za-z][A-Za-z0-9_]*)+$')
EXAMPLES = """examples:
  python -m exodigit_nodes.glove                      # sine session until Ctrl-C
  python -m exodigit_nodes.glove --duration 20        # 20 s, then stop and exit 0
  python -m exodigit_nodes.glove --mode staircase --record --out runs/stairs
  python -m exodigit_nodes.glove --params-file my_glove.yaml --namespace /left/index
  python -m exodigit_nodes.glove --clock sim --real-time-factor 0 --lockstep --duration 60
                                                      # 60 simulated s, as fast as the CPU allows

ROS_AUTOMATIC_DISCOVERY_RANGE (default LOCALHOST) and ROS_DOMAIN_ID (default 0) are passed to
every node; see the README, "Networking"."""


class UsageError(ValueError):
    """A command-line value the glove refuses before starting anything."""


def build_parser() -> argparse.ArgumentParser:
    """The command-line interface of ``python -m exodigit_nodes.glove``."""
    parser = argparse.ArgumentParser(
        prog='python -m exodigit_nodes.glove',
        description='Run the simulated soft glove (plant, estimator, pressure_command) with a\n'
        'live summary; write a run record (CSV and PNG) of the published signals.',
        epilog=EXAMPLES,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    parser.add_argument(
        '--duration',
        type=float,
        default=0.0,
        metavar='S',
        help='seconds to run (simulated seconds with --clock sim), then stop cleanly and exit 0; '
        '0 (default) runs until Ctrl-C',
    )
    parser.add_argument(
        '--clock',
        choices=CLOCK.choices,
        default=CLOCK.default,
        help=f'wall: the system clock; sim: the plant owns simulated time (/clock) and the other '
        f'nodes use it (default {CLOCK.default})',
    )
    parser.add_argument(
        '--real-time-factor',
        type=float,
        default=REAL_TIME_FACTOR.default,
        metavar='X',
        help='with --clock sim: simulated seconds per wall second; 0 = as fast as possible '
        f'(default {REAL_TIME_FACTOR.default:g})',
    )
    parser.add_argument(
        '--lockstep',
        action='store_true',
        help='with --clock sim: one step in flight; the plant waits for pressure_command to '
        'answer each step (exact and repeatable at any speed)',
    )
    parser.add_argument(
        '--namespace', default='/glove', help='ROS namespace of the glove (default /glove)'
    )
    parser.add_argument(
        '--mode',
        choices=MODE.choices,
        default=MODE.default,
        help=f'pressure_command mode (default {MODE.default}: {MODES[MODE.default]})',
    )
    parser.add_argument(
        '--params-file',
        metavar='FILE',
        help='model parameter YAML (MODEL.md section 10) of the glove, for every node; default '
        'built-in values',
    )
    parser.add_argument(
        '--patient',
        default=DEFAULT_PATIENT,
        metavar='NAME|FILE',
        help=f'the finger the plant simulates (MODEL.md section 11): a preset '
        f'({", ".join(PATIENT_PRESETS)}), a patient YAML, or nominal (the glove file alone); '
        f'the estimator and pressure_command assume the nominal one. Default {DEFAULT_PATIENT}',
    )
    parser.add_argument(
        '--ros-params',
        action='append',
        default=[],
        metavar='FILE',
        help='ROS parameter YAML (ros__parameters) passed to every node with --params-file; '
        'may be repeated',
    )
    parser.add_argument(
        '--record',
        action='store_true',
        help='also record every topic to a rosbag2 MCAP bag in the run directory',
    )
    parser.add_argument(
        '--out',
        metavar='DIR',
        help='run directory for the record (default runs/<YYYYmmdd-HHMMSS>)',
    )
    return parser


def check_arguments(args: argparse.Namespace) -> None:
    """Refuse values that would make a node fail later, with one line naming the value.

    Raises
    ------
    UsageError
        For a negative or non-finite duration, a malformed namespace, or a parameter file that
        cannot be read or breaks a rule of the model.
    """
    if not 0.0 <= args.duration < float('inf'):
        raise UsageError(f'--duration {args.duration}: must be a finite number of seconds >= 0')
    if not 0.0 <= args.real_time_factor <= MAX_REAL_TIME_FACTOR:
        raise UsageError(
            f'--real-time-factor {args.real_time_factor}: must lie in [0, '
            f'{MAX_REAL_TIME_FACTOR:g}] (0 = as fast as possible)'
        )
    if args.clock != 'sim' and (
        args.lockstep or args.real_time_factor != REAL_TIME_FACTOR.default
    ):
        raise UsageError('--lockstep and --real-time-factor need --clock sim')
    if not NAMESPACE_PATTERN.match(args.namespace):
        raise UsageError(
            f'--namespace {args.namespace!r}: must be absolute, e.g. /glove or /left/index '
            '(letters, digits, underscores)'
        )
    from exodigit_model import ParameterError, load_params

    try:
        load_params(nominal_files(args))
    except ParameterError as error:
        raise UsageError(f'--params-file: {" ".join(str(error).split())}') from None
    try:
        load_params(plant_files(args))
    except ParameterError as error:
        raise UsageError(f'--patient: {" ".join(str(error).split())}') from None
    for path in args.ros_params:
        if not Path(path).is_file():
            raise UsageError(f'--ros-params {path}: no such file')


def node_command(node: str, args: argparse.Namespace, record: RunRecord) -> list[str]:
    """The command line of one node process (same Python, ``-m exodigit_nodes.<node>``)."""
    command = [sys.executable, '-m', f'exodigit_nodes.{node}']
    if node == 'recorder':
        command += ['--output', str(record.bag_path)]
    command += ['--ros-args', '-r', f'__ns:={args.namespace}']
    for path in args.ros_params:
        command += ['--params-file', str(Path(path).resolve())]
    files = plant_files(args) if node == 'plant' else nominal_files(args)
    if node in NODES and files:  # each node loads the model: the plant with the patient
        listed = ','.join("'" + str(Path(f).resolve()).replace("'", "''") + "'" for f in files)
        command += ['-p', f'params_file:=[{listed}]']
    if node == 'pressure_command':
        command += ['-p', f'mode:={args.mode}']
    if args.clock == 'sim':
        command += sim_time_arguments(node, args)
    return command


def nominal_files(args: argparse.Namespace) -> list[str]:
    """The model files the estimator and the controller assume (the glove, nominal finger)."""
    return [] if args.params_file is None else [args.params_file]


def plant_files(args: argparse.Namespace) -> list[str]:
    """The plant's model files: the glove, then the patient merged over it."""
    from exodigit_model import PATIENT_PRESETS, patient_file

    if args.patient == NOMINAL_PATIENT:
        return nominal_files(args)
    patient = patient_file(args.patient) if args.patient in PATIENT_PRESETS else args.patient
    return [*nominal_files(args), str(patient)]


def identification_references(args: argparse.Namespace) -> dict:
    """Nominal and simulated patient's stiffness and rest angle, to show beside the estimate."""
    from exodigit_model import load_params

    joints = {
        label: load_params(files).finger.joints
        for label, files in (('nominal', nominal_files(args)), ('patient', plant_files(args)))
    }
    return {
        'estimated_finger_stiffness': {
            label: [j.stiffness for j in rows] for label, rows in joints.items()
        },
        'estimated_rest_angle': {
            label: [j.rest_angle for j in rows] for label, rows in joints.items()
        },
    }


def sim_time_arguments(node: str, args: argparse.Namespace) -> list[str]:
    """The ``-p`` overrides of one node for simulated time (the plant owns /clock)."""
    lockstep = 'true' if args.lockstep else 'false'
    if node == 'plant':
        # Paused until the summary listens (nothing is missed), and again at the end of the
        # duration, so that the record ends exactly there however far behind the summary is.
        return [
            *('-p', 'clock:=sim'),
            *('-p', 'start_paused:=true'),
            *('-p', f'pause_at:={args.duration!r}'),
            *('-p', f'real_time_factor:={args.real_time_factor!r}'),
            *('-p', f'lockstep:={lockstep}'),
        ]
    overrides = ['-p', 'use_sim_time:=true']
    if node == 'pressure_command':
        overrides += ['-p', f'lockstep:={lockstep}']
    return overrides


class StopRequest:
    """Turns SIGINT, SIGTERM and SIGHUP into a flag the main loop checks."""

    def __init__(self):
        self.requested = False
        self.signal_name = ''
        self.install()

    def install(self) -> None:
        """Handle SIGINT, SIGTERM and SIGHUP (terminal closed), also if SIGINT was ignored."""
        for sig in (signal.SIGINT, signal.SIGTERM, signal.SIGHUP):
            signal.signal(sig, self._handle)

    def _handle(self, signum, _frame) -> None:
        self.requested = True
        self.signal_name = signal.Signals(signum).name


def log_tail(path: Path | None) -> list[str]:
    """The last lines of a node's log file (empty if there is none)."""
    if path is None or not path.is_file():
        return []
    lines = path.read_text(errors='replace').splitlines()
    return lines[-LOG_TAIL_LINES:]


def main(argv=None) -> int:
    """Run the glove; return the exit code (0 clean stop, 1 a node failed, 2 bad input)."""
    args = build_parser().parse_args(argv)
    try:
        check_arguments(args)
        settings = discovery_settings(os.environ)
    except ValueError as error:
        print(f'glove: {error}', file=sys.stderr)
        return 2
    env = settings.apply(os.environ)
    os.environ.update(env)  # this process's own ROS context reads the same settings
    try:
        run_dir = Path(args.out) if args.out else new_run_directory(Path('runs'))
        record = RunRecord(run_dir)
    except OSError as error:
        print(f'glove: cannot write the run record: {error}', file=sys.stderr)
        return 2
    print(settings.describe())
    print(
        f'glove {args.namespace}: mode {args.mode}, patient {args.patient} (the controller and '
        f'estimator assume the nominal finger); run record and node logs in {run_dir}/'
    )
    return run_glove(args, env, record)


def run_glove(args: argparse.Namespace, env: dict, record: RunRecord) -> int:
    """Start the processes, show the summary until stop or failure, stop, write the record."""
    stop = StopRequest()  # from here on, Ctrl-C means a clean stop
    import rclpy
    from rclpy.executors import SingleThreadedExecutor
    from rclpy.signals import SignalHandlerOptions

    from exodigit_nodes.monitor import GloveMonitor

    stop.install()  # again: loading rclpy's C extension takes the signals over
    supervisor = Supervisor(env, log_dir=record.log_dir)
    names = (('recorder',) if args.record else ()) + NODES
    display = SummaryDisplay(sys.stdout, sys.stdout.isatty() and os.environ.get('TERM') != 'dumb')
    clock = '' if args.clock == 'wall' else ', simulated time' + (', lockstep' * args.lockstep)
    title = f'exodigit glove {args.namespace} ({args.mode}{clock})'
    references = identification_references(args)
    signals = GloveSignals(NODES, references)
    executor = monitor = None
    failures, stops = [], []
    try:
        for name in names:
            supervisor.start(name, node_command(name, args, record))
        rclpy.init(args=[], signal_handler_options=SignalHandlerOptions.NO)
        monitor = GloveMonitor(signals, args.namespace, record.write)
        executor = SingleThreadedExecutor()
        executor.add_node(monitor)

        def spin() -> None:
            executor.spin_once(timeout_sec=0.02)

        started = time.monotonic()
        next_refresh = started
        waiting = args.clock == 'sim'  # the plant starts paused until we listen to every topic
        while not stop.requested:
            spin()
            now = time.monotonic()
            if waiting and monitor.connected(SIGNALS):
                waiting = not monitor.resume_plant()
            failures = supervisor.exited()
            elapsed = now - started if args.clock == 'wall' else signals.received_stamp or 0.0
            if failures or (args.duration and elapsed >= args.duration):
                break
            if now >= next_refresh:
                display.show(signals, now, title)
                record.flush()
                next_refresh = now + REFRESH_PERIOD
        display.show(signals, time.monotonic(), title)
        reason = stop.signal_name or (
            'a node exited'
            if failures
            else f'{args.duration:g} {"" if args.clock == "wall" else "simulated "}s elapsed'
        )
        display.message(f'stopping ({reason}): {", ".join(supervisor.running())}')
        stops = supervisor.stop(STOP_ORDER, idle=spin)
        for sample in signals.flush():  # the nodes are gone: the last step is complete
            record.write(sample)
    finally:
        supervisor.stop(STOP_ORDER)  # after an error above: no node is left behind
        if executor is not None:
            executor.shutdown()
        if monitor is not None:
            monitor.destroy_node()
        rclpy.try_shutdown()
        record.close()

    failed_names = {exit_.name for exit_ in failures}
    unclean = [s for s in stops if not s.clean and s.name not in failed_names]
    # A node stopped before it ever reported was still starting (importing): Ctrl-C that
    # early can end it with any code, and that is no failure of the session.
    starting = [
        s for s in unclean if s.name in NODES and signals.health[s.name] is None and not s.forced
    ]
    for exit_ in starting:
        print(f'glove: {exit_.name} was stopped while starting ({exit_.describe()})')
    bad = failures + [s for s in unclean if s not in starting]
    for exit_ in bad:
        print(f'glove: {exit_.describe()}', file=sys.stderr)
        for line in log_tail(supervisor.log_path(exit_.name)):
            print(f'  {exit_.name}| {line}', file=sys.stderr)
    plot = record.plot(references)
    print(f'run record: {record.csv_path} ({record.rows} samples)')
    print(f'plot: {plot}' if plot else 'plot: none (no sample was received)')
    if args.record:
        print(f'rosbag2 (MCAP): {record.bag_path}')
    print(f'node logs: {record.log_dir}/')
    return 1 if bad else 0


if __name__ == '__main__':
    sys.exit(main())
