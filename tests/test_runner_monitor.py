"""The runner's glove monitor with a real rclpy context: it hands on every step left at the stop.

A monitor that fell behind on a loaded machine still held seconds of the nodes' last steps when
they stopped (fresh clone fc54: the run record ended 5 s before the zero pressure was sent).
"""

import os

import numpy as np
import pytest
import rclpy
from builtin_interfaces.msg import Time
from exodigit_nodes.nodes.qos import WRITER_QOS
from exodigit_nodes.runner.monitor import GloveMonitor
from exodigit_nodes.runner.summary import GloveSignals
from rclpy.duration import Duration
from rclpy.executors import SingleThreadedExecutor
from ros_harness import DISCOVERY_TIMEOUT, wait_until
from sensor_msgs.msg import JointState
from std_msgs.msg import Float64MultiArray, Header

NAMESPACE = f'/monitor_drain_{os.getpid()}'
STEPS = 300
PERIOD = 0.01
"""Seconds between the steps' stamps."""


@pytest.fixture
def context(ros_domain):
    context = rclpy.Context()
    rclpy.init(context=context, domain_id=ros_domain)
    yield context
    rclpy.try_shutdown(context=context)


def test_drain_hands_on_every_step_the_stopped_nodes_left(context):
    signals, samples = GloveSignals(['plant']), []
    monitor = GloveMonitor(signals, NAMESPACE, samples.append, context=context)
    executor = SingleThreadedExecutor(context=context)
    executor.add_node(monitor)
    plant = rclpy.create_node('plant', namespace=NAMESPACE, context=context)
    publishers = {
        topic: plant.create_publisher(kind, topic, WRITER_QOS)
        for topic, kind in (
            ('chamber_pressure', Float64MultiArray),
            ('joint_states', JointState),
            ('contact_forces', Float64MultiArray),
        )
    }
    assert wait_until(
        lambda: all(p.get_subscription_count() >= 1 for p in publishers.values()),
        DISCOVERY_TIMEOUT,
    )
    for step in range(STEPS):  # the monitor takes none meanwhile: it is not spun
        for topic, publisher in publishers.items():  # a plant step: pressure first
            publisher.publish(step_message(topic, step))
    for publisher in publishers.values():
        assert publisher.wait_for_all_acked(Duration(seconds=DISCOVERY_TIMEOUT))
    plant.destroy_node()  # the plant is gone, its steps wait in the monitor's readers
    monitor.drain(lambda: executor.spin_once(timeout_sec=0.02))
    samples += signals.flush()  # the last step: no next pressure completes it
    executor.shutdown()
    monitor.destroy_node()

    assert monitor.taken == len(publishers) * STEPS
    assert len(samples) == STEPS  # every step, in order, none mixed with another
    for step, sample in enumerate(samples):
        assert sample.time == pytest.approx(step * PERIOD, abs=1e-9)
        for topic in publishers:
            np.testing.assert_array_equal(sample.values[topic], step_values(topic, step))


def step_values(topic, step):
    """What the plant's step ``step`` says on ``topic``: distinct per topic and step."""
    scale = {'chamber_pressure': 1e3, 'joint_states': 1e-3, 'contact_forces': 1e-2}[topic]
    return scale * step * np.array([1.0, 2.0, 3.0])


def step_message(topic, step):
    """The message of ``topic`` in step ``step`` (angles stamped at step · PERIOD)."""
    values = step_values(topic, step).tolist()
    if topic != 'joint_states':
        return Float64MultiArray(data=values)
    stamp = Time(sec=int(step * PERIOD), nanosec=round(step * PERIOD % 1 * 1e9))
    return JointState(header=Header(stamp=stamp), name=['mcp', 'pip', 'dip'], position=values)
