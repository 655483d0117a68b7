"""Record every topic of a glove or a hand to a rosbag2 bag in MCAP storage (no ROS install).

Usage::

    python -m exodigit_nodes.nodes.recorder --output DIR --ros-args -r __ns:=/glove
    python -m exodigit_nodes.nodes.recorder --output DIR --gloves a,b --ros-args -r __ns:=/hand

The raw CDR messages of every glove topic (:data:`TOPICS`), written with the ``rosbags``
library, each stamped with the time it was sent (its DDS source timestamp; under
``use_sim_time`` the node clock on arrival), so that a step's messages stay together however late
they arrived. Ctrl-C or SIGTERM closes the bags cleanly. ``~/ready``: docs/spec/ros.md, "The
session protocol", guarantee 2; the rest: docs/tools.md, "Recording a session".
"""

from __future__ import annotations

import argparse
import sys
from functools import partial
from pathlib import Path

from diagnostic_msgs.msg import DiagnosticArray
from rclpy.node import Node
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
from .process import parse_own_arguments, serve
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
SHARED = (messages.DIAGNOSTICS, messages.CLOCK)
"""Topics of the whole domain, not of a glove: every bag gets them."""


class Recorder(Node):
    """Subscribes to the glove topics (raw CDR) and writes each message to its bags (``rosbags``).

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
        try:
            from rosbags.rosbag2 import StoragePlugin, Writer, WriterError
            from rosbags.typesys import Stores, get_typestore
        except ImportError:
            raise ConfigurationError(
                'rosbags is not installed; install it with: pip install rosbags'
            ) from None
        if gloves != ('',) and ('' in gloves or len(set(gloves)) != len(gloves)):
            raise ConfigurationError(f'--gloves {",".join(gloves)}: give distinct names')
        if output.exists():
            raise ConfigurationError(
                f'--output {output}: exists already; the bag needs a new folder'
            )
        typestore = get_typestore(Stores.ROS2_JAZZY)
        self.bags = []
        self.taken = 0  # messages taken so far, each once whatever the number of its bags
        self._routes: dict[str, list] = {}  # resolved topic: its (bag, connection) pairs
        for glove in gloves:
            bag = Writer(output / glove, version=BAG_VERSION, storage_plugin=StoragePlugin.MCAP)
            try:
                bag.open()  # with the folders it needs
            except (WriterError, OSError) as error:
                raise ConfigurationError(
                    f'--output {output}: cannot create the bag ({error})'
                ) from None
            self.bags.append(bag)
            for topic, message_class in TOPICS.items():  # in their order (TOPICS)
                relative = f'{glove}/{topic}' if glove and topic not in SHARED else topic
                name = self.resolve_topic_name(relative)
                if name not in self._routes:
                    self._routes[name] = []
                    callback = WithInfo(partial(self._record, name))
                    qos = record_profile(name)
                    self.create_subscription(message_class, name, callback, qos, raw=True)
                # Its ROS 2 type name, e.g. std_msgs/msg/Float64MultiArray.
                package = message_class.__module__.split('.')[0]
                msgtype = f'{package}/msg/{message_class.__name__}'
                connection = bag.add_connection(name, msgtype, typestore=typestore)
                self._routes[name].append((bag, connection))
        self.get_logger().info(
            f'recording {len(self._routes)} topics to {output} (rosbag2, MCAP): '
            + ', '.join(self._routes)
        )
        self.readiness = Ready(self, glove_nodes(gloves, nodes))  # after every reader

    def _record(self, topic: str, data: bytes, info: dict) -> None:
        """Write a message of ``topic`` (raw CDR) to its bags, stamped with its send time.

        Its first is logged: a sign of a matched publisher, which a test waits for.
        """
        self.taken += 1
        clock = self.get_clock()
        stamp = info['source_timestamp']
        if clock.ros_time_is_active or not stamp:
            stamp = clock.now().nanoseconds
        for bag, connection in self._routes[topic]:
            bag.write(connection, stamp, data)
        if bag.counts[connection.id] == 1:  # in each of its bags from the start
            self.get_logger().info(f'first message on {topic}')

    def close(self) -> None:
        """Close the bags (the MCAP file, then metadata.yaml) and log what each holds."""
        for bag in self.bags:
            bag.close()
            counts = ', '.join(f'{c.topic} {bag.counts[c.id]}' for c in bag.connections)
            self.get_logger().info(f'closed {bag.path}: {counts} messages')


def main(args: list[str] | None = None) -> int:
    """Console script ``recorder`` (``ros2 run exodigit_nodes recorder --output DIR``).

    A stop signal sets a flag the spin loop checks (:func:`.serve`): the bag closes outside rclpy.
    """
    parser = argparse.ArgumentParser(
        prog='python -m exodigit_nodes.nodes.recorder',
        description='Record every glove topic of the namespace (or of --gloves in it) to a '
        'rosbag2 MCAP bag, until Ctrl-C or SIGTERM.',
        epilog='example:\n  timeout 20 python -m exodigit_nodes.nodes.recorder --output runs/bag '
        '--ros-args -r __ns:=/glove',
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
    argv = sys.argv if args is None else ['recorder', *args]
    options = parse_own_arguments(parser, argv)
    return serve(
        'recorder',
        argv,
        lambda: Recorder(
            Path(options.output),
            tuple(options.gloves.split(',')),
            tuple(options.nodes.split(',')),
        ),
        Recorder.close,
        taken=lambda recorder: recorder.taken,
    )


if __name__ == '__main__':
    raise SystemExit(main())
