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

from exodigit_nodes.logic.options import UsageError, check_namespace, with_patient
from exodigit_nodes.logic.pacing import TimeSettings
from exodigit_nodes.nodes import catalog
from exodigit_nodes.nodes.messages import SET_PAUSED
from exodigit_nodes.nodes.run_options import (
    BOOLEANS,
    RunOption,
    add_options,
    check_sim_only,
    namespace_option,
    parameter_option,
    patient_option,
    text,
    time_options,
    time_parameters,
    time_settings,
)
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
#: The plant's simulated-time parameters the glove has options for (besides ``--clock``).
TIME_OPTIONS = ('real_time_factor', 'lockstep')
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


def glove_options() -> tuple[RunOption, ...]:
    """The glove's own options, in ``--help`` order (:mod:`.nodes.run_options`, as the hand's)."""
    return (
        *time_options(TIME_OPTIONS),
        namespace_option('/glove', 'the glove'),
        parameter_option('mode'),
        RunOption(
            'params_file',
            '',
            'model parameter YAML (docs/spec/model.md §10) of the glove, for every node; default '
            'built-in values',
            metavar='FILE',
        ),
        patient_option(DEFAULT_PATIENT, 'the glove file'),
        RunOption(
            'record',
            'false',
            'also record every topic to a rosbag2 MCAP bag in the run directory',
            choices=BOOLEANS,
            switch=True,
        ),
    )


def build_parser() -> argparse.ArgumentParser:
    """The command-line interface of ``python -m exodigit_nodes.glove``."""
    parser = argparse.ArgumentParser(
        prog='python -m exodigit_nodes.glove',
        description='Run the simulated soft glove (plant, estimator, pressure_command) with a\n'
        'live summary; write a run record (CSV and PNG) of the published signals.\n'
        'Switches (--lockstep, --record) take true or false; alone they mean true.',
        epilog=EXAMPLES,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    add_session_arguments(parser)
    add_options(parser, glove_options())
    return parser


def check_arguments(args: argparse.Namespace) -> None:
    """Refuse values that would make a node fail later, with one line naming the value.

    Reads the text options into their values in place (``lockstep``, ``record``: bool;
    ``real_time_factor``: float), with the hand's checks (:mod:`.nodes.run_options`).

    Raises
    ------
    UsageError
        For a negative or non-finite duration, a real-time factor out of range, simulated-time
        options on the wall clock, a malformed namespace, or a parameter file that cannot be
        read or breaks a rule of the model.
    """
    check_session_arguments(args)
    time = time_settings({name: getattr(args, name) for name in TIME_OPTIONS})
    check_sim_only(args.clock, time, TIME_OPTIONS)
    args.real_time_factor, args.lockstep = time.real_time_factor, time.lockstep
    args.record = args.record == 'true'
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
    return [args.params_file] if args.params_file else []


def plant_files(args: argparse.Namespace) -> list[str]:
    """The plant's model files: the glove, then the patient merged over it."""
    return with_patient(nominal_files(args), args.patient)


def sim_time_arguments(node: str, args: argparse.Namespace) -> list[str]:
    """The ``-p`` overrides of one node for simulated time (the plant owns /clock).

    The hand's (:func:`.nodes.run_options.time_parameters`), with the plant paused until the
    summary listens (nothing is missed) and again at the end of the duration, so that the
    record ends exactly there however far behind the summary is.
    """
    time = TimeSettings(
        real_time_factor=args.real_time_factor,
        lockstep=args.lockstep,
        start_paused=True,
        pause_at=args.duration,
    )
    names = (*TIME_OPTIONS, 'start_paused', 'pause_at')
    values = time_parameters(node, 'sim', time, names)
    return [word for name, value in values.items() for word in ('-p', f'{name}:={text(value)}')]


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
