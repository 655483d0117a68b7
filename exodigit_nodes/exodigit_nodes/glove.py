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
import sys
from pathlib import Path

from exodigit_model.control import MODES
from exodigit_model.params import PATIENT_PRESETS

from exodigit_nodes.logic.options import UsageError, check_namespace, with_patient
from exodigit_nodes.logic.pacing import MAX_REAL_TIME_FACTOR
from exodigit_nodes.nodes import catalog
from exodigit_nodes.nodes.messages import SET_PAUSED
from exodigit_nodes.runner.common import (
    add_session_arguments,
    check_session_arguments,
    start_session,
)
from exodigit_nodes.runner.run_record import RunRecord
from exodigit_nodes.runner.session import (
    Session,
    WatchedGlove,
    identification_references,
)

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
EXAMPLES = """examples:
  python -m exodigit_nodes.glove                      # sine session until Ctrl-C
  python -m exodigit_nodes.glove --duration 20        # 20 s, then stop and exit 0
  python -m exodigit_nodes.glove --mode staircase --record --out runs/stairs
  python -m exodigit_nodes.glove --params-file my_glove.yaml --namespace /left/index
  python -m exodigit_nodes.glove --clock sim --real-time-factor 0 --lockstep --duration 60
                                                      # 60 simulated s, as fast as the CPU allows

ROS_AUTOMATIC_DISCOVERY_RANGE (default LOCALHOST) and ROS_DOMAIN_ID (default 0) are passed to
every node; see the README, "Networking"."""


def build_parser() -> argparse.ArgumentParser:
    """The command-line interface of ``python -m exodigit_nodes.glove``."""
    parser = argparse.ArgumentParser(
        prog='python -m exodigit_nodes.glove',
        description='Run the simulated soft glove (plant, estimator, pressure_command) with a\n'
        'live summary; write a run record (CSV and PNG) of the published signals.',
        epilog=EXAMPLES,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    add_session_arguments(parser)
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
        help='model parameter YAML (docs/spec/model.md §10) of the glove, for every node; default '
        'built-in values',
    )
    parser.add_argument(
        '--patient',
        default=DEFAULT_PATIENT,
        metavar='NAME|FILE',
        help=f'the finger the plant simulates (docs/spec/model.md §11): a preset '
        f'({", ".join(PATIENT_PRESETS)}), a patient YAML, or nominal (the glove file alone); '
        f'the estimator and pressure_command assume the nominal one. Default {DEFAULT_PATIENT}',
    )
    parser.add_argument(
        '--record',
        action='store_true',
        help='also record every topic to a rosbag2 MCAP bag in the run directory',
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
    check_session_arguments(args)
    if not 0.0 <= args.real_time_factor <= MAX_REAL_TIME_FACTOR:
        raise UsageError(
            f'--real-time-factor {args.real_time_factor}: must lie in [0, '
            f'{MAX_REAL_TIME_FACTOR:g}] (0 = as fast as possible)'
        )
    if args.clock != 'sim' and (
        args.lockstep or args.real_time_factor != REAL_TIME_FACTOR.default
    ):
        raise UsageError('--lockstep and --real-time-factor need --clock sim')
    check_namespace(args.namespace, '/glove or /left/index')
    from exodigit_model import ParameterError, load_params

    try:
        load_params(nominal_files(args))
    except ParameterError as error:
        raise UsageError(f'--params-file: {" ".join(str(error).split())}') from None
    try:
        load_params(plant_files(args))
    except ParameterError as error:
        raise UsageError(f'--patient: {" ".join(str(error).split())}') from None


def node_command(node: str, args: argparse.Namespace, record: RunRecord) -> list[str]:
    """The command line of one node process (same Python, ``-m exodigit_nodes.nodes.<node>``)."""
    command = [sys.executable, '-m', f'exodigit_nodes.nodes.{node}']
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
    return with_patient(nominal_files(args), args.patient)


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


def main(argv=None) -> int:
    """Run the glove; return the exit code (0 clean stop, 1 a node failed, 2 bad input)."""
    args = build_parser().parse_args(argv)
    try:
        check_arguments(args)
    except ValueError as error:  # UsageError
        print(f'glove: {error}', file=sys.stderr)
        return 2

    def prepare(run_dir: Path) -> tuple[Session, str]:
        record = RunRecord(run_dir)
        bag = f'; rosbag2 (MCAP) in {record.bag_path}' if args.record else ''
        banner = (
            f'glove {args.namespace}: mode {args.mode}, patient {args.patient} (the controller '
            f'and estimator assume the nominal finger); run record and node logs in {run_dir}/'
            f'{bag}'
        )
        return glove_session(args, record), banner

    return start_session('glove', args.out, prepare)


def glove_session(args: argparse.Namespace, record: RunRecord) -> Session:
    """The :class:`.session.Session` of one glove: three processes (and the recorder)."""
    names = (('recorder',) if args.record else ()) + NODES
    clock = '' if args.clock == 'wall' else ', simulated time' + (', lockstep' * args.lockstep)
    glove = WatchedGlove(
        title=f'exodigit glove {args.namespace} ({args.mode}{clock})',
        namespace=args.namespace,
        record=record,
        references=identification_references(nominal_files(args), plant_files(args)),
    )
    return Session(
        program='glove',
        processes=tuple((name, node_command(name, args, record)) for name in names),
        stop_order=STOP_ORDER,
        runs={name: (name,) if name in NODES else () for name in names},
        nodes=NODES,
        gloves=(glove,),
        pause_service=f'{args.namespace}/{SET_PAUSED}',
        simulated=args.clock == 'sim',
        duration=args.duration,
        log_dir=record.log_dir,
        listeners=('recorder',) if args.record else (),
    )


if __name__ == '__main__':
    sys.exit(main())
