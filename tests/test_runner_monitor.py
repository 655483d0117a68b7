"""The runner's glove monitor with a real rclpy context: it hands on every step left at the stop.

A monitor that fell behind on a loaded machine still held seconds of the nodes' last steps when
they stopped (fresh clone fc54: the run record ended 5 s before the zero pressure was sent).
"""

import os

import numpy as np
import pytest
from exodigit_nodes.logic.backlog import take_backlog
from exodigit_nodes.runner.monitor import GloveMonitor
from exodigit_nodes.runner.summary import GloveSignals
from rclpy.duration import Duration
from rclpy.executors import SingleThreadedExecutor
from ros_harness import DISCOVERY_TIMEOUT, wait_until
from stand_in_plant import PERIOD, send_steps, stand_in_plant, step_values

NAMESPACE = f'/monitor_drain_{os.getpid()}'
STEPS = 300


def test_taking_the_backlog_hands_on_every_step_the_stopped_nodes_left(ros_context):
    signals, samples = GloveSignals(['plant']), []
    monitor = GloveMonitor(signals, NAMESPACE, samples.append, context=ros_context)
    executor = SingleThreadedExecutor(context=ros_context)
    executor.add_node(monitor)
    plant, publishers = stand_in_plant(ros_context, NAMESPACE)
    assert wait_until(
        lambda: all(p.get_subscription_count() >= 1 for p in publishers.values()),
        DISCOVERY_TIMEOUT,
    )
    send_steps(publishers, STEPS)  # the monitor takes none meanwhile: it is not spun
    for publisher in publishers.values():
        assert publisher.wait_for_all_acked(Duration(seconds=DISCOVERY_TIMEOUT))
    plant.destroy_node()  # the plant is gone, its steps wait in the monitor's readers
    take_backlog(lambda: executor.spin_once(timeout_sec=0.02), lambda: monitor.taken)
    samples += signals.flush()  # the last step: no next pressure completes it
    executor.shutdown()
    monitor.destroy_node()

    assert monitor.taken == len(publishers) * STEPS
    assert len(samples) == STEPS  # every step, in order, none mixed with another
    for step, sample in enumerate(samples):
        assert sample.time == pytest.approx(step * PERIOD, abs=1e-9)
        for topic in publishers:
            np.testing.assert_array_equal(sample.values[topic], step_values(topic, step))
