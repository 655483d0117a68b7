"""Record every topic of a glove or a hand to a rosbag2 bag in MCAP storage (no ROS install).

Usage::

    python -m exodigit_nodes.nodes.recorder --output DIR [--duration S] --ros-args -r __ns:=/glove
    python -m exodigit_nodes.nodes.recorder --output DIR --gloves a,b --ros-args -r __ns:=/hand

Subscribes to every glove topic (:data:`TOPICS`) in its namespace, or in each sub-namespace of
``--gloves`` (a bag each), and writes the raw CDR messages with the ``rosbags`` library, each
stamped with the time it was sent (its DDS source timestamp; under ``use_sim_time`` the node
clock on arrival), so that a step's messages stay together however late they arrived. Its
``~/ready`` is docs/spec/ros.md, "The session protocol", guarantee 2. The bag opens in ``ros2
bag``, Foxglove and PlotJuggler (``exodigit plot DIR`` draws it); Ctrl-C, SIGTERM or the end of
``--duration`` closes it cleanly, a topic nobody published listed with 0 messages.
"""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path

from diagnostic_msgs.msg import DiagnosticArray
from rclpy.node import Node
from rclpy.utilities import remove_ros_args
from rosgraph_msgs.msg import Clock
from sensor_msgs.msg import JointState
from std_msgs.msg import Float64MultiArray
from trajectory_msgs.msg import JointTrajectory
from visualization_msgs.msg import MarkerArray

from . import messages
from .catalog import PLANT_NODE
from .handshake import Ready, glove_nodes
from .message_info import WithInfo
from .node_base import ConfigurationError
from .process import serve
from .qos import record_profile

TOPICS = {
    messages.CHAMBER_PRESSURE: Float64MultiArray,
    messages.JOINT_STATES: JointState,
    messages.PRESSURE_COMMAND: Float64MultiArray,
    messages.APPLIED_COMMAND: Float64MultiArray,
    messages.CONTACT_FORCES: Float64MultiArray,
    messages.SEGMENT_LENGTHS: Float64MultiArray,
    messages.PATIENT_EFFORT: Float64MultiArray,
    messages.ESTIMATED_CONTACT_FORCES: JointState,
    messages.ESTIMATED_FINGER_STIFFNESS: Float64MultiArray,
    messages.ESTIMATED_FINGER_TORQUE: JointState,
    messages.ESTIMATED_REST_ANGLE: Float64MultiArray,
    messages.JOINT_TARGETS: Float64MultiArray,
    messages.JOINT_TRAJECTORY: JointTrajectory,
    messages.MARKERS: MarkerArray,
    messages.DIAGNOSTICS: DiagnosticArray,
    messages.CLOCK: Clock,
}
"""Recorded topics (relative names resolve in the node's namespace) and their message types.

Subscribed in this order, which the executor keeps for messages waiting: a recorder behind still
logs a step's pressure before its angles, as the plant sends them (``exodigit plot`` pairs them
by log time, :mod:`exodigit_model.stepping.joining`)."""

BAG_VERSION = 9
"""rosbag2 metadata version written (the one ROS 2 Jazzy writes)."""


def type_name(message_class: type) -> str:
    """ROS 2 type name of an rclpy message class, e.g. ``std_msgs/msg/Float64MultiArray``."""
    package = message_class.__module__.split('.')[0]
    return f'{package}/msg/{message_class.__name__}'


class BagWriter:
    """A rosbag2 MCAP bag being written: one connection per topic, raw CDR messages in.

    Parameters
    ----------
    path : Path
        Bag folder to create (must not exist).
    topics : dict
        Fully resolved topic name -> ROS 2 type name.
    """

    def __init__(self, path: Path, topics: dict[str, str]) -> None:
        try:
            from rosbags.rosbag2 import StoragePlugin, Writer, WriterError
            from rosbags.typesys import Stores, get_typestore
        except ImportError:
            raise ConfigurationError(
                'rosbags is not installed; install it with: pip install rosbags'
            ) from None
        if path.exists():
            raise ConfigurationError(
                f'--output {path}: exists already; the bag needs a new folder'
            )
        typestore = get_typestore(Stores.ROS2_JAZZY)
        self.path = path
        self._writer = Writer(path, version=BAG_VERSION, storage_plugin=StoragePlugin.MCAP)
        try:
            self._writer.open()
        except (WriterError, OSError) as error:
            raise ConfigurationError(f'--output {path}: cannot create the bag ({error})') from None
        self._connections = {
            topic: self._writer.add_connection(topic, msgtype, typestore=typestore)
            for topic, msgtype in topics.items()
        }
        self.counts = dict.fromkeys(topics, 0)

    def write(self, topic: str, stamp_ns: int, data: bytes) -> None:
        """Append one serialized message received at ``stamp_ns`` (node clock, ns)."""
        self._writer.write(self._connections[topic], stamp_ns, data)
        self.counts[topic] += 1

    def close(self) -> None:
        """Finish the MCAP file and write metadata.yaml."""
        self._writer.close()


SHARED = (messages.DIAGNOSTICS, messages.CLOCK)
"""Topics of the whole domain, not of a glove: every bag gets them."""


class Recorder(Node):
    """Subscribes to the glove topics (raw CDR) and hands each message to its :class:`BagWriter`.

    ``gloves``: sub-namespaces of its namespace whose topics it records, each to a bag of its own,
    ``output/<glove>`` (a hand's fingers; ``exodigit plot`` reads one glove a bag); the default
    ``('',)``: the namespace itself, to ``output``. /diagnostics and /clock go to every bag.
    ``nodes``: the nodes of each glove that must have matched its readers before it says it is
    ready (the plant alone by default). ``node_options`` go to :class:`rclpy.node.Node`
    (``context``, ``namespace``).
    """

    def __init__(
        self,
        output: Path,
        gloves: tuple[str, ...] = ('',),
        nodes: tuple[str, ...] = (PLANT_NODE.executable,),
        **node_options,
    ) -> None:
        super().__init__('recorder', **node_options)
        if gloves != ('',):
            if '' in gloves or len(set(gloves)) != len(gloves):
                raise ConfigurationError(f'--gloves {",".join(gloves)}: give distinct names')
            if output.exists():
                raise ConfigurationError(
                    f'--output {output}: exists already; the bags need a new folder'
                )
            output.mkdir(parents=True)
        routes: dict[str, tuple[type, list[str]]] = {}  # relative topic: type, its gloves' bags
        for glove in gloves:  # a glove's chamber_pressure before its joint_states (TOPICS)
            for topic, message_class in TOPICS.items():
                name = f'{glove}/{topic}' if glove and topic not in SHARED else topic
                routes.setdefault(name, (message_class, []))[1].append(glove)
        self._names = {}
        self._taken = 0
        for name, (message_class, _) in routes.items():
            subscription = self.create_subscription(
                message_class,
                name,
                WithInfo(self._callback_for(name)),
                record_profile(name),
                raw=True,
            )
            self._names[name] = subscription.topic_name
        self._routes = {name: bags for name, (_, bags) in routes.items()}
        self.bags = {
            glove: BagWriter(
                output / glove if glove else output,
                {self._names[n]: type_name(c) for n, (c, bags) in routes.items() if glove in bags},
            )
            for glove in gloves
        }
        self.get_logger().info(
            f'recording {len(routes)} topics to {output} (rosbag2, MCAP): '
            + ', '.join(self._names.values())
        )
        self.readiness = Ready(self, glove_nodes(gloves, nodes))  # after every reader

    def _callback_for(self, topic: str):
        """The subscription callback of ``topic``.

        It logs the first message: a sign of a matched publisher, which a test waits for.
        """
        heard = False

        def record(data: bytes, info: dict) -> None:
            nonlocal heard
            self._taken += 1
            clock = self.get_clock()
            stamp = info['source_timestamp']
            if clock.ros_time_is_active or not stamp:
                stamp = clock.now().nanoseconds
            for glove in self._routes[topic]:
                self.bags[glove].write(self._names[topic], stamp, data)
            if not heard:
                heard = True
                self.get_logger().info(f'first message on {self._names[topic]}')

        return record

    def taken(self) -> int:
        """Messages taken so far (each once, whatever the number of bags it went to)."""
        return self._taken

    def close(self) -> None:
        """Close the bags and log what each holds."""
        for bag in self.bags.values():
            bag.close()
            counts = ', '.join(f'{topic} {count}' for topic, count in bag.counts.items())
            self.get_logger().info(f'closed {bag.path}: {counts} messages')


def parse_arguments(argv: list[str]) -> argparse.Namespace:
    """The recorder's own options (``--ros-args`` removed first)."""
    parser = argparse.ArgumentParser(
        prog='python -m exodigit_nodes.nodes.recorder',
        description='Record every glove topic of the namespace (or of --gloves in it) to a '
        'rosbag2 MCAP bag.',
        epilog='example:\n  python -m exodigit_nodes.nodes.recorder --output runs/bag '
        '--duration 20 --ros-args -r __ns:=/glove',
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    parser.add_argument('--output', required=True, metavar='DIR', help='bag folder to create')
    parser.add_argument(
        '--gloves',
        default='',
        metavar='A,B',
        help="comma-separated sub-namespaces of gloves to record (a hand's fingers), each to "
        'a bag DIR/<glove>; default the namespace itself, to DIR',
    )
    parser.add_argument(
        '--nodes',
        default=PLANT_NODE.executable,
        metavar='A,B',
        help='comma-separated nodes of each glove that must have matched the readers before '
        'the recorder says it is ready on ~/ready (default: %(default)s)',
    )
    parser.add_argument(
        '--duration',
        type=float,
        default=0.0,
        metavar='S',
        help='stop after S seconds (0 = until Ctrl-C)',
    )
    options = parser.parse_args(argv)
    if not options.duration >= 0.0 or options.duration == float('inf'):
        parser.error(f'--duration {options.duration}: must be a finite number >= 0 (s)')
    return options


def main(args: list[str] | None = None) -> int:
    """Console script ``recorder`` (``ros2 run exodigit_nodes recorder --output DIR``).

    A stop signal sets a flag the spin loop checks (:func:`.serve`): the bag closes outside rclpy.
    """
    argv = sys.argv if args is None else ['recorder', *args]
    try:
        own = remove_ros_args(argv)[1:]
    except RuntimeError as error:  # rclpy's RCLInvalidROSArgsError: malformed --ros-args
        print(f'recorder: error: {" ".join(str(error).split())}', file=sys.stderr)
        return 2
    options = parse_arguments(own)
    return serve(
        'recorder',
        argv,
        lambda: Recorder(
            Path(options.output),
            tuple(options.gloves.split(',')),
            tuple(options.nodes.split(',')),
        ),
        Recorder.close,
        taken=Recorder.taken,
        duration=options.duration if options.duration > 0 else math.inf,
    )


if __name__ == '__main__':
    raise SystemExit(main())
