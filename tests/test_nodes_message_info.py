"""A callback that takes message info gets it on both of rclpy's executors (nodes/message_info.py).

The estimator pairs by the DDS source timestamps and publication numbers of its messages and
spins on rclpy's EventsExecutor: this is the case a plain ``(message, info)`` function fails
on with rclpy 7.1.
"""

import time

import pytest
import rclpy
from exodigit_nodes.nodes.message_info import WithInfo
from rclpy.executors import SingleThreadedExecutor
from rclpy.experimental import EventsExecutor
from std_msgs.msg import Int64

COUNT = 5
WAIT = 30.0  # s, at most, for the messages to come round (a loaded machine)


@pytest.mark.parametrize('executor_class', [EventsExecutor, SingleThreadedExecutor])
def test_a_callback_gets_every_message_with_its_info(ros_context, executor_class):
    node = rclpy.create_node('message_info_test', context=ros_context)
    executor = executor_class(context=ros_context)
    received, sent = [], []

    def on_number(message: Int64, info: dict) -> None:
        received.append((message.data, info['publication_sequence_number']))
        sent.append(info['source_timestamp'])

    node.create_subscription(Int64, 'numbers', WithInfo(on_number), COUNT)
    publisher = node.create_publisher(Int64, 'numbers', COUNT)
    executor.add_node(node)
    deadline = time.monotonic() + WAIT
    while publisher.get_subscription_count() < 1 and time.monotonic() < deadline:
        executor.spin_once(timeout_sec=0.05)
    for number in range(1, COUNT + 1):
        publisher.publish(Int64(data=number))
    while len(received) < COUNT and time.monotonic() < deadline:
        executor.spin_once(timeout_sec=0.05)
    executor.shutdown()
    node.destroy_node()
    assert received == [(number, number) for number in range(1, COUNT + 1)]
    assert 0 < sent[0] <= sent[-1]  # ns, DDS source timestamps in send order
