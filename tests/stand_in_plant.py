"""A stand-in plant for tests of what records the plant's steps (monitor, recorder).

Step k on each of the three topics a plant step joins, sent in the plant's order (pressure,
angles, forces): values distinct per topic and step (:func:`step_values`), angles stamped at
k · :data:`PERIOD`, so a sample or a bag row shows which step it holds.
"""

import numpy as np
import rclpy
from builtin_interfaces.msg import Time
from exodigit_nodes.nodes.qos import STREAM_QOS
from sensor_msgs.msg import JointState
from std_msgs.msg import Float64MultiArray, Header

TOPICS = {
    'chamber_pressure': Float64MultiArray,
    'joint_states': JointState,
    'contact_forces': Float64MultiArray,
}
"""The topics of a plant step, in the order the plant sends them, and their types."""
PERIOD = 0.01
"""Seconds between the steps' stamps."""
SCALES = {'chamber_pressure': 1e3, 'joint_states': 1e-3, 'contact_forces': 1e-2}


def step_values(topic, step):
    """What the plant's step ``step`` says on ``topic``: distinct per topic and step."""
    return SCALES[topic] * step * np.array([1.0, 2.0, 3.0])


def step_message(topic, step):
    """The message of ``topic`` in step ``step`` (angles stamped at step · PERIOD)."""
    values = step_values(topic, step).tolist()
    if topic != 'joint_states':
        return Float64MultiArray(data=values)
    stamp = Time(sec=int(step * PERIOD), nanosec=round(step * PERIOD % 1 * 1e9))
    return JointState(header=Header(stamp=stamp), name=['mcp', 'pip', 'dip'], position=values)


def stand_in_plant(context, namespace):
    """A node ``plant`` in ``namespace`` with the glove's publishers of :data:`TOPICS`."""
    plant = rclpy.create_node('plant', namespace=namespace, context=context)
    publishers = {
        topic: plant.create_publisher(kind, topic, STREAM_QOS) for topic, kind in TOPICS.items()
    }
    return plant, publishers


def send_steps(publishers, steps):
    """Send steps 0 .. ``steps`` - 1, each on every topic in the plant's order."""
    for step in range(steps):
        for topic, publisher in publishers.items():
            publisher.publish(step_message(topic, step))
