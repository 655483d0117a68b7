"""The runner's glove monitor with a real rclpy context: it takes every step left at the stop.

A monitor that fell behind on a loaded machine still held seconds of the nodes' last steps when
they stopped (fresh clone fc54: the run record ended 5 s before the zero pressure was sent).
"""

import os

import pytest
import rclpy
from exodigit_nodes.runner.monitor import GloveMonitor
from exodigit_nodes.runner.summary import GloveSignals
from rclpy.duration import Duration
from rclpy.executors import SingleThreadedExecutor
from ros_harness import DISCOVERY_TIMEOUT, TEST_QOS, wait_until
from sensor_msgs.msg import JointState

NAMESPACE = f'/monitor_drain_{os.getpid()}'
STEPS = 300


@pytest.fixture
def context(ros_domain):
    context = rclpy.Context()
    rclpy.init(context=context, domain_id=ros_domain)
    yield context
    rclpy.try_shutdown(context=context)


def test_drain_takes_every_message_the_stopped_nodes_left(context):
    samples = []
    monitor = GloveMonitor(GloveSignals(['plant']), NAMESPACE, samples.append, context=context)
    executor = SingleThreadedExecutor(context=context)
    executor.add_node(monitor)
    plant = rclpy.create_node('plant', namespace=NAMESPACE, context=context)
    publisher = plant.create_publisher(JointState, 'joint_states', TEST_QOS)
    assert wait_until(lambda: publisher.get_subscription_count() >= 1, DISCOVERY_TIMEOUT)
    message = JointState(name=['mcp', 'pip', 'dip'])
    for step in range(STEPS):  # the monitor takes none meanwhile: it is not spun
        message.position = [0.001 * step] * 3
        publisher.publish(message)
    assert publisher.wait_for_all_acked(Duration(seconds=DISCOVERY_TIMEOUT))
    plant.destroy_node()  # the plant is gone, its steps wait in the monitor's reader
    monitor.drain(lambda: executor.spin_once(timeout_sec=0.02))
    assert monitor.taken == STEPS
    executor.shutdown()
    monitor.destroy_node()
