"""The one runner of ``python -m exodigit_nodes.glove`` and ``.hand``: a hand of N fingers.

docs/running.md ("Running the glove", "A whole hand") has the two commands; a lone glove
runs each node as its own process (``launch/glove.launch.py``), a hand of fingers runs every node
in one ``hand_nodes`` process (``launch/hand.launch.py``). The command nodes stop first, so the
chambers get zero pressure while the plant still runs.

``--hardware`` (docs/hardware.md): the ``hardware`` bridge takes the plant's place; ``emulated``
starts ``mcu_emulator`` first and stops it last, its pty at ``<run>/board``. ``--record``: one
rosbag2 ``recorder`` for the whole hand (one per finger left plants undiscovered on a loaded
machine), started first and stopped last. ``--clock sim``: the plants start paused and are held
at ``--duration`` (``run_until``: :mod:`.horizon`), so every record ends there.
"""

from __future__ import annotations

import argparse
import math
import os
import sys
from collections.abc import Sequence
from dataclasses import dataclass, replace
from pathlib import Path

from ..logic.options import UsageError
from ..logic.ros_env import discovery_environment, ros_args
from ..nodes.catalog import ESTIMATOR_NODE
from ..nodes.hand_config import EMULATED, HandConfig, command_options, hand_config
from ..nodes.messages import SET_PAUSED
from ..nodes.run_options import add_options
from .run_record import BAG_DIR_NAME, LOG_DIR_NAME, RunRecord, new_run_directory
from .session import Session, WatchedGlove, identification_references, run_session
from .summary import BOARD_STEP_ORDER, STEP_ORDER

HAND_PROCESS = 'hand_nodes'
"""The one process of every node of a hand of fingers (its executable)."""
RECORDER = 'recorder'
"""The rosbag2 recorder's process, node and module name."""
EMULATOR = 'mcu_emulator'
"""The emulated board's process (``--hardware emulated``)."""
BOARD_LINK_NAME = 'board'
"""The emulated board's port in the run directory (a link to its pty)."""


@dataclass(frozen=True)
class Command:
    """One command of the runner: its name (in messages and titles) and ``--help`` text.

    Attributes
    ----------
    name : str
        ``glove`` or ``hand``: its option table (:func:`..nodes.hand_config.command_options`).
    description : str
        ``--help``'s description.
    examples : str
        ``--help``'s epilog.
    """

    name: str
    description: str
    examples: str


@dataclass(frozen=True)
class RunConfig:
    """One run: the hand, how long, what else it writes.

    Attributes
    ----------
    program : str
        The command's name, in messages and summary titles.
    hand : HandConfig
        With ``clock`` sim, paused at the start (the session holds it at ``duration``). A lone
        glove runs a process per node, a hand of fingers one :data:`HAND_PROCESS`.
    duration : float
        Seconds to run (simulated with ``clock`` sim); 0 until stopped.
    ros_params : tuple of str
        ROS parameter files for every node, absolute.
    record : bool
        A rosbag2 recorder of every glove.
    """

    program: str
    hand: HandConfig
    duration: float = 0.0
    ros_params: tuple[str, ...] = ()
    record: bool = False


def build_parser(command: Command) -> argparse.ArgumentParser:
    """The command line of ``python -m exodigit_nodes.<command>``."""
    parser = argparse.ArgumentParser(
        prog=f'python -m exodigit_nodes.{command.name}',
        description=command.description,
        epilog=command.examples,
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
        '--ros-params',
        action='append',
        default=[],
        metavar='FILE',
        help='ROS parameter YAML (ros__parameters; /**: for every node) passed to every node '
        'with --params-file; may be repeated',
    )
    parser.add_argument(
        '--out', metavar='DIR', help='run directory (default runs/<YYYYmmdd-HHMMSS>)'
    )
    add_options(parser, command_options(command.name))
    return parser


def run_config(command: Command, options: argparse.Namespace) -> RunConfig:
    """The run of parsed :func:`build_parser` options, checked before anything starts.

    Raises
    ------
    UsageError
        One line naming the option: a negative or non-finite duration, a missing ROS parameter
        file, any refusal of :func:`..nodes.hand_config.hand_config`, or a model or patient file
        that cannot be read or breaks a rule of the model.
    """
    if not 0.0 <= options.duration < math.inf:
        raise UsageError(f'--duration {options.duration}: must be a finite number of seconds >= 0')
    for path in options.ros_params:
        if not Path(path).is_file():
            raise UsageError(f'--ros-params {path}: no such file')
    hand = hand_config(options)
    from exodigit_model import ParameterError, load_params

    for glove in hand.gloves():
        for option, files in (
            ('--params-file', glove.model_files),
            ('--patient', glove.plant_files),
        ):
            try:
                load_params(list(files))
            except ParameterError as error:
                raise UsageError(f'{option}: {" ".join(str(error).split())}') from None
    if hand.clock == 'sim':
        hand = replace(hand, time=replace(hand.time, start_paused=True))
    return RunConfig(
        program=command.name,
        hand=hand,
        duration=options.duration,
        ros_params=tuple(str(Path(path).resolve()) for path in options.ros_params),
        record=options.record == 'true',
    )


def _params_files(paths: Sequence[str]) -> list[str]:
    return [word for path in paths for word in ('--params-file', path)]


def ros_arguments(namespace: str, ros_params: Sequence[str], values: dict) -> list[str]:
    """``--ros-args`` of one node process: its namespace, the ROS parameter files, ``values``.

    A list value is of files (``params_file``), made absolute.
    """
    values = {
        name: [str(Path(item).resolve()) for item in value] if isinstance(value, list) else value
        for name, value in values.items()
    }
    return ros_args(values, namespace, extra=_params_files(ros_params))


def node_processes(config: RunConfig, emulator_link: str = '') -> dict[str, list[str]]:
    """The processes of the run's nodes, name to command line, in start order.

    ``emulator_link``: the emulated board's port (``--hardware emulated``).
    """
    hand = config.hand
    if not hand.fingers:
        (glove,) = hand.gloves()
        return {
            entry.executable: [
                sys.executable,
                '-m',
                entry.module,
                *ros_arguments(
                    glove.namespace,
                    config.ros_params,
                    hand.parameters(entry.executable, glove, emulator_link),
                ),
            ]
            for entry in hand.node_entries()
        }
    command = [sys.executable, '-m', 'exodigit_nodes.nodes.hand_nodes', *hand.arguments()]
    files = _params_files(config.ros_params)
    return {HAND_PROCESS: [*command, *(['--ros-args', *files] if files else [])]}


def recorder_command(config: RunConfig, bag: Path) -> list[str]:
    """The recorder's command line: every glove's topics to ``bag`` (a finger's: ``bag/f``)."""
    hand = config.hand
    values = {'use_sim_time': hand.clock == 'sim'}
    return [
        *(sys.executable, '-m', f'exodigit_nodes.nodes.{RECORDER}'),
        *('--output', str(bag)),
        *(('--gloves', ','.join(hand.fingers)) if hand.fingers else ()),
        *('--nodes', ','.join(entry.executable for entry in hand.node_entries())),
        *ros_arguments(hand.namespace, config.ros_params, values),
    ]


def emulator_command(config: RunConfig, link: Path) -> list[str]:
    """``mcu_emulator`` serving at ``link``: the glove's plant model (the patient's finger)."""
    (glove,) = config.hand.gloves()
    emulator = [sys.executable, '-m', 'exodigit_nodes.hardware.emulator', '--link', str(link)]
    return [*emulator, *_params_files(glove.plant_files)]


def session(config: RunConfig, run_dir: Path) -> Session:
    """The :class:`.session.Session` of the run: its processes, one watched glove per finger."""
    hand = config.hand
    clock = '' if hand.clock == 'wall' else ', simulated time' + ', lockstep' * hand.time.lockstep
    board = f', board {hand.hardware}' if hand.hardware else ''
    simulated = hand.hardware in ('', EMULATED)  # a patient is simulated (not a real board)
    watched = tuple(
        WatchedGlove(
            title=f'exodigit {config.program} {glove.namespace} ({hand.mode}{clock}{board})',
            namespace=glove.namespace,
            record=RunRecord(run_dir / glove.finger),  # a lone glove's: the run directory
            references=identification_references(
                list(glove.model_files), list(glove.plant_files) if simulated else None
            ),
        )
        for glove in hand.gloves()
    )
    recorders = (
        {RECORDER: recorder_command(config, run_dir / BAG_DIR_NAME)} if config.record else {}
    )
    link = run_dir / BOARD_LINK_NAME
    emulated = hand.hardware == EMULATED
    boards = {EMULATOR: emulator_command(config, link)} if emulated else {}
    nodes = node_processes(config, str(link) if emulated else '')
    estimated = hand.gloves() if hand.estimator else ()
    executables = tuple(entry.executable for entry in hand.node_entries())
    return Session(
        program=config.program,
        processes=(*recorders.items(), *boards.items(), *nodes.items()),
        # the command nodes first, the plants (a board's bridge, then the board) last
        stop_order=(*reversed(nodes), *boards, *recorders),
        runs={
            **dict.fromkeys((*recorders, *boards), ()),
            **{name: executables if name == HAND_PROCESS else (name,) for name in nodes},
        },
        nodes=executables,
        gloves=watched,
        pause_service=f'{hand.namespace.rstrip("/")}/{SET_PAUSED}',
        simulated=hand.clock == 'sim',
        duration=config.duration,
        log_dir=run_dir / LOG_DIR_NAME,
        listeners=(
            *(f'{hand.namespace.rstrip("/")}/{RECORDER}' for _ in recorders),
            *(f'{glove.namespace.rstrip("/")}/{ESTIMATOR_NODE.executable}' for glove in estimated),
        ),
        streams=BOARD_STEP_ORDER if hand.hardware else STEP_ORDER,
    )


def banner(config: RunConfig, session: Session) -> str:
    """The line that says what runs and where its records go."""
    hand = config.hand
    fingers = f'fingers {", ".join(hand.fingers)}, ' if hand.fingers else ''
    run_dir = session.log_dir.parent
    patient = f'patient {hand.patient}'
    if hand.hardware == EMULATED:
        patient += f' on the emulated board {run_dir / BOARD_LINK_NAME}'
    elif hand.hardware:
        patient = f'the board on {hand.hardware}, the finger in the glove'
    return (
        f'{config.program} {hand.namespace}: {fingers}mode {hand.mode}, {patient} '
        '(the controllers and estimators assume the nominal finger); run records and node logs '
        f'in {run_dir}/'
        + (f'; rosbag2 (MCAP) in {run_dir / BAG_DIR_NAME}' if config.record else '')
    )


def main(command: Command, argv: Sequence[str] | None = None) -> int:
    """Run ``command``; the exit code (0 clean stop, 1 a process failed, 2 bad input).

    The discovery settings of the environment (docs/networking.md) go to every process and to
    this one's own ROS context. 2, with one line on stderr, for refused options or settings or a
    run directory (``--out``, default a new ``runs/<time>``) that cannot be written.
    """
    options = build_parser(command).parse_args(argv)
    try:
        config = run_config(command, options)
        env, discovery = discovery_environment(os.environ)
    except ValueError as error:  # UsageError
        print(f'{command.name}: {error}', file=sys.stderr)
        return 2
    os.environ.update(env)  # this process's own ROS context reads the same settings
    try:
        run_dir = Path(options.out) if options.out else new_run_directory(Path('runs'))
        started = session(config, run_dir)
    except OSError as error:
        print(f'{command.name}: cannot write the run record: {error}', file=sys.stderr)
        return 2
    print(discovery)
    print(banner(config, started))
    return run_session(started, env)
