"""What the glove and hand runners share on their command line and at start.

Both take ``--duration``, ``--ros-params`` and ``--out`` (:func:`add_session_arguments`, checked by
:func:`check_session_arguments`) and a ``--namespace`` (:func:`..logic.options.check_namespace`),
and both start the same way once their own options are checked (:func:`start_session`): the
discovery settings, the run directory, then :func:`.session.run_session`.
"""

from __future__ import annotations

import argparse
import math
import os
import sys
from collections.abc import Callable
from pathlib import Path

from ..logic.options import UsageError
from ..logic.ros_env import discovery_settings
from .run_record import new_run_directory
from .session import Session, run_session


def add_session_arguments(parser: argparse.ArgumentParser) -> None:
    """Put ``--duration``, ``--ros-params`` and ``--out`` on ``parser``."""
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


def check_session_arguments(options: argparse.Namespace) -> None:
    """Refuse a negative or non-finite duration and a missing ROS parameter file (UsageError)."""
    if not 0.0 <= options.duration < math.inf:
        raise UsageError(f'--duration {options.duration}: must be a finite number of seconds >= 0')
    for path in options.ros_params:
        if not Path(path).is_file():
            raise UsageError(f'--ros-params {path}: no such file')


def start_session(
    program: str, out: str | None, prepare: Callable[[Path], tuple[Session, str]]
) -> int:
    """Run the session ``prepare(run_dir)`` returns, with its one-line banner; the exit code.

    The discovery settings of the environment (README "Networking") go to every process and to
    this one's own ROS context. 2 when they are refused or the run directory (``out``, default
    a new ``runs/<time>``) cannot be written, else :func:`.session.run_session`'s code.
    """
    try:
        settings = discovery_settings(os.environ)
    except ValueError as error:
        print(f'{program}: {error}', file=sys.stderr)
        return 2
    env = settings.apply(os.environ)
    os.environ.update(env)  # this process's own ROS context reads the same settings
    try:
        run_dir = Path(out) if out else new_run_directory(Path('runs'))
        session, banner = prepare(run_dir)
    except OSError as error:
        print(f'{program}: cannot write the run record: {error}', file=sys.stderr)
        return 2
    print(settings.describe())
    print(banner)
    return run_session(session, env)
