"""What a plant publishes at each step, and ``applied_command`` (docs/spec/ros.md).

Made before the plant's inputs: a controller that sees the plant's command subscription has seen
its outputs announced too.
"""

from __future__ import annotations

from array import array

from rclpy.node import Node
from sensor_msgs.msg import JointState
from std_msgs.msg import Float64MultiArray

from exodigit_model import JOINT_NAMES, GloveState

from .messages import (
    APPLIED_COMMAND,
    CHAMBER_PRESSURE,
    CONTACT_FORCES,
    JOINT_STATES,
    SEGMENT_LENGTHS,
    fill,
    joint_vector_message,
    valve_command_message,
)
from .qos import APPLIED_QOS, STREAM_QOS


class PlantOutputs:
    """A plant's output publishers, with their messages filled and reused.

    Parameters
    ----------
    node : rclpy.node.Node
        The plant.
    joint_prefix : str
        Put before MCP, PIP and DIP in the joint names of ``joint_states``.
    valves : bool
        ``applied_command`` is six openings (the plant takes ``valve_command``), not pressures.
    """

    def __init__(self, node: Node, joint_prefix: str, *, valves: bool) -> None:
        self.joint_state = JointState(name=[joint_prefix + name for name in JOINT_NAMES])
        self.pressure_message = joint_vector_message()
        self.force_message = joint_vector_message()
        self.length_message = joint_vector_message()
        self.applied_message = valve_command_message() if valves else joint_vector_message()
        vector = Float64MultiArray
        self.pressures = node.create_publisher(vector, CHAMBER_PRESSURE, STREAM_QOS)
        self.joints = node.create_publisher(JointState, JOINT_STATES, STREAM_QOS)
        self.forces = node.create_publisher(vector, CONTACT_FORCES, STREAM_QOS)
        self.lengths = node.create_publisher(vector, SEGMENT_LENGTHS, STREAM_QOS)
        self.applied = node.create_publisher(vector, APPLIED_COMMAND, APPLIED_QOS)
        self.publishers = (self.pressures, self.joints, self.forces, self.lengths, self.applied)
        """Every output publisher (:meth:`.Plant.readers_matched` asks about them)."""

    def publish_applied(self, command) -> None:
        """``applied_command``: the command the next step applies (Pa, or openings)."""
        self.applied.publish(fill(self.applied_message, command))

    def publish_state(self, state: GloveState, stamp) -> None:
        """Publish the step's chamber_pressure, joint_states, contact_forces, segment_lengths."""
        message = self.joint_state
        message.header.stamp = stamp
        message.position = array('d', state.q_measured)
        message.velocity = array('d', state.qdot)
        message.effort = array('d', state.finger_torque)
        fill(self.pressure_message, state.pressure_measured)
        fill(self.force_message, state.forces)
        fill(self.length_message, state.lengths)
        # Pressure first, then the rest, back to back: the estimator, the live summary and
        # exodigit plot pair a step's messages by the times they were sent, each with the
        # chamber_pressure sent before it (exodigit_model.stepping.joining).
        self.pressures.publish(self.pressure_message)
        self.joints.publish(message)
        self.forces.publish(self.force_message)
        self.lengths.publish(self.length_message)
