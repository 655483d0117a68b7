"""``hand_nodes``: the nodes of every glove of a hand in one process.

For each finger of ``--fingers`` (default the five), in namespace ``<namespace>/<finger>`` with
joint names ``<finger>_mcp, ...``: a ``plant`` of the finger's model file
(``config/hand/<finger>.yaml``, with ``--patient`` merged over it), an ``estimator`` and a
``pressure_command`` in ``--mode``, both assuming the finger's nominal model. Every finger keeps
its own topics, services, parameters and /diagnostics, exactly as a glove started node by node;
only the processes differ. ``--estimator false`` leaves the estimators out. The hand runner and
the launch file start a hand as this one process (docs/running.md, "A whole hand", has its speed).

Time: with ``--clock wall`` each plant steps on the system clock. With ``--clock sim`` the hand
has one simulated time (:class:`.sim_time.SimulatedTime`): every finger steps together, ``/clock``
is published once per step, ``<namespace>/set_paused`` and ``<namespace>/step`` control the
whole hand, and with ``--lockstep`` each step waits for every finger's controller.

ROS arguments after ``--ros-args`` apply to every node (``-p rate_hz:=200``, or
``--params-file`` with ``/**:`` parameters); the per-finger values above win over them.
Every node spins on one rclpy EventsExecutor (the estimators' message-info callbacks through
:class:`.message_info.WithInfo`). Ctrl-C / SIGTERM: every command node sends zero pressure, then
all nodes stop. Exit status 0 after a clean stop, 2 for a refused configuration
(one line on stderr).

Run: ``python -m exodigit_nodes.nodes.hand_nodes --fingers index,middle --ros-args -p
rate_hz:=200`` (``ros2 run exodigit_nodes hand_nodes ...``); ``python -m exodigit_nodes.hand`` adds
the live
summary and the run records.
"""

from __future__ import annotations

import argparse
import sys

from rclpy.node import Node
from rclpy.parameter import Parameter
from rclpy.utilities import remove_ros_args

from ..logic.options import UsageError
from .hand_config import HandConfig, command_options, hand_config
from .plant import Plant
from .process import freeze_start_up, last_words, serve
from .run_options import add_options
from .sim_time import SimulatedTime


def build_hand(config: HandConfig) -> list[Node]:
    """The nodes of the hand in start order: the owner of its simulated time (clock sim) first."""
    nodes: list[Node] = []
    shared = None
    if config.clock == 'sim':
        owner = Node('hand', namespace=config.namespace)  # owns /clock, set_paused, step
        shared = SimulatedTime(owner, config.time)
        nodes.append(owner)
    classes = [entry.node_class() for entry in config.node_entries()]
    for glove in config.gloves():
        for node_class in classes:
            options = {'sim_time': shared} if node_class is Plant else {}
            values = config.parameters(node_class.executable, glove)
            nodes.append(
                node_class(
                    namespace=glove.namespace,
                    parameter_overrides=[Parameter(k, value=v) for k, v in values.items()],
                    **options,
                )
            )
    return nodes


def build_parser() -> argparse.ArgumentParser:
    """The command line of ``hand_nodes``."""
    parser = argparse.ArgumentParser(
        prog='hand_nodes',
        description='Run the plant, estimator and pressure_command of every finger of a hand '
        'in this one process.',
        epilog='ROS arguments for every node go after --ros-args, e.g. --ros-args -p '
        'rate_hz:=200. Switches (lockstep, estimator...) take true or false; alone they mean '
        'true.',
    )
    add_options(parser, command_options('hand_nodes'))
    return parser


def main(args: list[str] | None = None) -> int:
    """Console script ``hand_nodes``; exit 0 after a clean stop, 2 for a refused configuration."""
    argv = sys.argv if args is None else ['hand_nodes', *args]
    try:
        options = build_parser().parse_args(remove_ros_args(argv)[1:])
        config = hand_config(options)
    except (UsageError, RuntimeError) as error:
        print(f'hand_nodes: error: {" ".join(str(error).split())}', file=sys.stderr)
        return 2

    def make_nodes() -> list[Node]:
        nodes = build_hand(config)
        freeze_start_up()
        return nodes

    return serve('hand_nodes', argv, make_nodes, last_words)


if __name__ == '__main__':
    raise SystemExit(main())
