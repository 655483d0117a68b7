"""``hand_nodes``: every finger's plant, estimator and pressure_command in one process.

docs/running.md, "A whole hand", has what it runs (each finger as a glove started node by node)
and its speed. With ``--clock sim`` the hand has one simulated time
(:class:`.sim_time.SimulatedTime`, owned by the node ``<namespace>/hand``). ROS arguments after
``--ros-args`` apply to every node; the per-finger values (:meth:`.HandConfig.parameters`) win
over them: ``python -m exodigit_nodes.nodes.hand_nodes --fingers index,middle --ros-args -p
rate_hz:=200`` (``ros2 run exodigit_nodes hand_nodes ...``).
"""

from __future__ import annotations

import argparse
import sys

from rclpy.node import Node
from rclpy.parameter import Parameter

from ..logic.options import UsageError
from .hand_config import HandConfig, command_options, hand_config
from .plant import Plant
from .process import last_words, parse_own_arguments, serve
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
        config = hand_config(parse_own_arguments(build_parser(), argv))
    except UsageError as error:
        print(f'hand_nodes: error: {" ".join(str(error).split())}', file=sys.stderr)
        return 2
    return serve('hand_nodes', argv, lambda: build_hand(config), last_words)


if __name__ == '__main__':
    raise SystemExit(main())
