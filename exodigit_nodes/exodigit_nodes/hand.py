"""Run a simulated hand from one command, with a live summary and one run record per finger.

Starts ``hand_nodes`` twice (:mod:`.hand_nodes`): every finger's plant and pressure_command in
one process, every estimator in the other; shows each finger's signals on the terminal, writes
``<finger>/signals.csv`` and ``<finger>/signals.png`` into the run directory and stops on Ctrl-C
or after ``--duration`` seconds (simulated seconds with ``--clock sim``): every command node
sends zero pressure first. Finger f lives in ``<namespace>/<f>`` with joint prefix ``f_`` and
the model ``config/hand/<f>.yaml``.

This is what ``make run HAND=1`` calls; on a ROS 2 install ``ros2 launch exodigit_nodes
hand.launch.py`` starts the same processes without the summary.
"""

import argparse
import sys
from dataclasses import replace
from pathlib import Path

from exodigit_nodes.logic.options import UsageError
from exodigit_nodes.nodes.hand_config import HandConfig, add_hand_arguments, hand_config
from exodigit_nodes.runner.common import (
    add_session_arguments,
    check_session_arguments,
    start_session,
)
from exodigit_nodes.runner.run_record import LOG_DIR_NAME, RunRecord
from exodigit_nodes.runner.session import Session, WatchedGlove, identification_references

PROCESS = 'hand_nodes'
#: The hand's processes: name and ``hand_nodes --part`` (the controllers' process stops first).
PROCESSES = {PROCESS: 'gloves', 'hand_estimators': 'estimators'}
EXAMPLES = """examples:
  python -m exodigit_nodes.hand                                  # five fingers until Ctrl-C
  python -m exodigit_nodes.hand --fingers index,middle --duration 20
  python -m exodigit_nodes.hand --clock sim --lockstep --real-time-factor 0 --duration 60
                                                     # 60 simulated s, as fast as the CPU allows
  python -m exodigit_nodes.hand --ros-params fast.yaml  # /**: ros__parameters: rate_hz: 200

ROS_AUTOMATIC_DISCOVERY_RANGE (default LOCALHOST) and ROS_DOMAIN_ID (default 0) are passed on;
see the README, "Networking"."""


def build_parser() -> argparse.ArgumentParser:
    """The command line of ``python -m exodigit_nodes.hand``."""
    parser = argparse.ArgumentParser(
        prog='python -m exodigit_nodes.hand',
        description="Run a simulated hand (every finger's plant and pressure_command in one "
        'process, the estimators in another) with a live summary; write a run record (CSV and '
        'PNG) per finger.',
        epilog=EXAMPLES,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    add_session_arguments(parser)
    add_hand_arguments(parser)
    return parser


def session_config(options: argparse.Namespace) -> HandConfig:
    """The hand to start: simulated time starts paused and pauses at the duration."""
    check_session_arguments(options)
    config = hand_config(options)
    from exodigit_model import ParameterError, load_params

    for finger in config.fingers:
        try:
            load_params(config.plant_files(finger))
        except ParameterError as error:
            raise UsageError(f'--patient: {" ".join(str(error).split())}') from None
    if config.clock != 'sim':
        return config
    # Paused until the summary listens (nothing is missed), and again at the end of the
    # duration, so that every record ends exactly there.
    return replace(config, time=replace(config.time, start_paused=True, pause_at=options.duration))


def hand_session(config: HandConfig, options: argparse.Namespace, run_dir: Path) -> Session:
    """The :class:`.session.Session` of a hand: its processes, one watched glove per finger."""
    command = [sys.executable, '-m', f'exodigit_nodes.nodes.{PROCESS}', *config.arguments()]
    ros_args = []
    for path in options.ros_params:
        ros_args += ['--params-file', str(Path(path).resolve())]
    if ros_args:
        ros_args.insert(0, '--ros-args')
    runs = {}  # the nodes of each process that has any (no estimators: one process)
    processes = []
    for name, part in PROCESSES.items():
        if entries := config.node_entries(part):
            runs[name] = tuple(entry.executable for entry in entries)
            processes.append((name, [*command, '--part', part, *ros_args]))
    nodes = tuple(entry.executable for entry in config.node_entries())
    clock = (
        '' if config.clock == 'wall' else ', simulated time' + ', lockstep' * config.time.lockstep
    )
    gloves = tuple(
        WatchedGlove(
            title=f'exodigit hand {config.finger_namespace(finger)} ({config.mode}{clock})',
            namespace=config.finger_namespace(finger),
            record=RunRecord(run_dir / finger),
            references=identification_references(
                config.model_files(finger), config.plant_files(finger)
            ),
        )
        for finger in config.fingers
    )
    return Session(
        program='hand',
        processes=tuple(processes),
        stop_order=tuple(PROCESSES),
        runs=runs,
        nodes=nodes,
        gloves=gloves,
        pause_service=f'{config.namespace.rstrip("/")}/set_paused',
        simulated=config.clock == 'sim',
        duration=options.duration,
        log_dir=run_dir / LOG_DIR_NAME,
    )


def main(argv=None) -> int:
    """Run the hand; the exit code (0 clean stop, 1 the process failed, 2 bad input)."""
    options = build_parser().parse_args(argv)
    try:
        config = session_config(options)
    except ValueError as error:  # UsageError
        print(f'hand: {error}', file=sys.stderr)
        return 2
    banner = (
        f'hand {config.namespace}: fingers {", ".join(config.fingers)}, mode {config.mode}, '
        f'patient {config.patient}; run records and logs in '
    )
    return start_session(
        'hand',
        options.out,
        lambda run_dir: (hand_session(config, options, run_dir), f'{banner}{run_dir}/'),
    )


if __name__ == '__main__':
    sys.exit(main())
