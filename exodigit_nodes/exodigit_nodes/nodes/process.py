"""A node's process from its command line to its last words: ``--help``, spin, stop, deliver.

:func:`run` is every glove node's ``main()``; :func:`serve` spins any nodes (the recorder's, a
hand's) and stops them so that nothing they sent is lost.
"""

from __future__ import annotations

import argparse
import gc
import signal
import sys
import time
from collections.abc import Callable

import rclpy
from rclpy.duration import Duration
from rclpy.executors import ExternalShutdownException
from rclpy.experimental import EventsExecutor
from rclpy.node import Node
from rclpy.qos import DurabilityPolicy
from rclpy.signals import SignalHandlerOptions
from rclpy.utilities import remove_ros_args

from ..logic.backlog import take_backlog
from ..logic.lifetime import StopRequest, stop_with_parent
from .dds import use_profile
from .handshake import matched_every_listed
from .node_base import ConfigurationError, GloveNode

POLL_PERIOD = 0.01
"""How often :func:`deliver` looks at a publisher's matches again, s."""
ACK_LIMIT = 2.0
"""Longest time a stopping process waits for its readers' acknowledgements, s (:func:`deliver`)."""
SPIN_PERIOD = 0.05
"""Longest time between two checks for a stop request while spinning, s."""


def run(node_class: type[GloveNode], args: list[str] | None = None) -> int:
    """Every glove node's ``main()``: its command line, then :func:`serve`; the exit status.

    A node's own command line is none but ``--help``, which prints its parameter table: argparse
    exits with 0 after the help and with 2 and a usage line for anything else, or malformed
    ``--ros-args``.
    """
    program = node_class.executable
    parser = argparse.ArgumentParser(
        prog=program,
        usage=f'{program} [-h] [--ros-args -p name:=value ...]',
        description=sys.modules[node_class.__module__].__doc__,
        epilog='parameters:\n' + node_class.table.help(),
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    try:
        parse_own_arguments(parser, [program, *(sys.argv[1:] if args is None else args)])
    except SystemExit as done:  # --help (0), or arguments that are not ours or malformed (2)
        return done.code
    return serve(program, args, node_class, last_words)


def parse_own_arguments(parser: argparse.ArgumentParser, argv: list[str]) -> argparse.Namespace:
    """``argv`` (the program first) without its ROS arguments, parsed by ``parser``.

    Malformed ``--ros-args`` are a usage error like any other: argparse's usage line, exit 2.
    """
    try:
        own = remove_ros_args(argv)[1:]
    except RuntimeError as error:  # rclpy's RCLInvalidROSArgsError
        parser.error(' '.join(str(error).split()))
    return parser.parse_args(own)


def last_words(node: Node) -> None:
    """A glove node's last words (:meth:`GloveNode.on_shutdown`) while its context is up.

    Nothing is tried after an external shutdown (``rclpy.shutdown()`` by the code that embeds
    the node), and one that comes while the node speaks ends its words without an error.
    """
    if isinstance(node, GloveNode) and node.context.ok():
        try:
            node.on_shutdown()
        except RuntimeError:  # rclpy's RCLError: the embedder shut rclpy down meanwhile
            if node.context.ok():
                raise


def serve(
    program: str,
    args: list[str] | None,
    make_nodes: Callable[[], Node | list[Node]],
    last_words: Callable[[Node], None],
    taken: Callable[[Node], int] | None = None,
) -> int:
    """Spin the node(s) ``make_nodes`` builds until a stop signal or shutdown.

    One EventsExecutor spins them (a third less CPU than the SingleThreadedExecutor at 100 Hz;
    callbacks that take message info are :class:`.message_info.WithInfo`). A stop signal, or the
    death of the process that started this one, only sets a flag checked every ``SPIN_PERIOD``
    (:mod:`..logic.lifetime`): no KeyboardInterrupt lands in rclpy's C code. Then a node that
    records (``taken``: the messages it has taken) takes its readers' backlog, each node says its
    ``last_words`` in the order built, and :func:`deliver` waits for their readers
    (docs/spec/ros.md, "The session protocol", guarantee 7).

    Returns
    -------
    int
        0 after a normal stop; 2 when the configuration is refused (a ConfigurationError: one
        line on stderr, no traceback); 1 when the process that started it is gone already.
    """
    stop = StopRequest()
    if not stop_with_parent(signal.SIGINT):
        print(f'{program}: the process that started it is gone; not starting', file=sys.stderr)
        return 1
    nodes: list[Node] = []
    code = 0
    try:
        try:
            use_profile()
            rclpy.init(args=args, signal_handler_options=SignalHandlerOptions.NO)
        except RuntimeError as error:  # rclpy's RCLError: malformed --ros-args
            raise ConfigurationError(' '.join(str(error).split())) from None
        made = make_nodes()
        nodes = made if isinstance(made, list) else [made]
        gc.collect()  # the long-lived start-up objects (model tables) out of the collector's way
        gc.freeze()
        executor = EventsExecutor()
        for node in nodes:
            executor.add_node(node)
        while not stop.requested:
            executor.spin_once(timeout_sec=SPIN_PERIOD)
        if taken is not None:  # what has arrived; nodes still running may send on meanwhile
            take_backlog(
                lambda: executor.spin_once(timeout_sec=0.0),
                lambda: sum(taken(node) for node in nodes),
            )
    except ConfigurationError as error:
        print(f'{program}: error: {error}', file=sys.stderr)
        code = 2
    except ExternalShutdownException:
        pass
    except RuntimeError:  # rclpy's RCLError of a callback that published as rclpy shut down
        if rclpy.ok():  # not a shutdown by the program that embeds the nodes: a failure
            raise
    finally:
        stop.ignore()
        for node in nodes:
            last_words(node)
        deliver(nodes)
        for node in nodes:
            node.destroy_node()
        rclpy.try_shutdown()
    return code


def deliver(nodes: list[Node]) -> None:
    """Wait until every reader of the nodes' publishers has acknowledged what they sent.

    A publisher that keeps history for late readers (transient-local) first waits for every
    reader the graph lists to match it. At most :data:`ACK_LIMIT` s in all; nothing after an
    external shutdown.
    """
    deadline = time.monotonic() + ACK_LIMIT
    try:
        for node in nodes:
            for publisher in node.publishers:
                if not node.context.ok():
                    return
                kept = publisher.qos_profile.durability == DurabilityPolicy.TRANSIENT_LOCAL
                while kept and not matched_every_listed(node, publisher):
                    if time.monotonic() >= deadline:
                        return
                    time.sleep(POLL_PERIOD)
                left = deadline - time.monotonic()
                if left <= 0.0:
                    return
                publisher.wait_for_all_acked(Duration(seconds=left))
    except RuntimeError:  # rclpy's RCLError: the code embedding the nodes shut rclpy down
        if rclpy.ok():
            raise
