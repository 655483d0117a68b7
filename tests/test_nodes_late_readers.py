"""A recording reader that matches a publisher late still gets what it sent before.

Discovery is per pair of processes and took up to 3 s on a loaded machine, while a plant in
simulated time stepped on: a hand's bag once held no step of a plant (fresh clone fc54). The
glove's publishers keep their last 1,000 samples for late readers (transient-local,
docs/spec/ros.md "QoS"), and the bag recorder and the runner's monitor read the plant's topics
that way. Here the stand-in plant's steps are all sent before the reader exists, so a reader
that gets only what is sent after it matched gets none.
"""

import os

import numpy as np
from exodigit_model.tools.bag import read_bag
from exodigit_nodes.nodes.qos import WRITER_DEPTH
from exodigit_nodes.nodes.recorder import Recorder
from exodigit_nodes.runner.monitor import GloveMonitor
from exodigit_nodes.runner.summary import GloveSignals
from rclpy.executors import SingleThreadedExecutor
from ros_harness import DISCOVERY_TIMEOUT, wait_until
from stand_in_plant import PERIOD, TOPICS, send_steps, stand_in_plant, step_values

NAMESPACE = f'/late_readers_{os.getpid()}'
STEPS = 300
"""Steps sent before the reader exists (fewer than the publishers keep: WRITER_DEPTH)."""


def expected(topic):
    return np.array([step_values(topic, step) for step in range(STEPS)])


def spin_until(executor, taken):
    """Spin ``executor`` until ``taken()`` counts every message of the STEPS steps."""

    def done():
        executor.spin_once(timeout_sec=0.01)
        return taken() >= len(TOPICS) * STEPS

    assert wait_until(done, DISCOVERY_TIMEOUT), taken()
    assert taken() == len(TOPICS) * STEPS


def test_the_publishers_keep_more_than_a_test_sends():
    assert WRITER_DEPTH > STEPS


def test_a_recorder_that_matches_late_records_every_step_sent_before(ros_context, tmp_path):
    namespace = f'{NAMESPACE}_bag'
    plant, publishers = stand_in_plant(ros_context, namespace)
    send_steps(publishers, STEPS)
    recorder = Recorder(tmp_path / 'bag', context=ros_context, namespace=namespace)
    executor = SingleThreadedExecutor(context=ros_context)
    executor.add_node(recorder)
    spin_until(executor, recorder.taken)
    recorder.close()
    executor.shutdown()
    recorder.destroy_node()
    plant.destroy_node()
    bag = read_bag(tmp_path / 'bag')
    for topic in TOPICS:
        np.testing.assert_array_equal(bag[topic].values, expected(topic), err_msg=topic)


def test_a_monitor_that_matches_late_takes_every_step_sent_before(ros_context):
    namespace = f'{NAMESPACE}_monitor'
    plant, publishers = stand_in_plant(ros_context, namespace)
    send_steps(publishers, STEPS)
    signals, samples = GloveSignals(['plant']), []
    monitor = GloveMonitor(signals, namespace, samples.append, context=ros_context)
    executor = SingleThreadedExecutor(context=ros_context)
    executor.add_node(monitor)
    spin_until(executor, lambda: monitor.taken)
    samples += signals.flush()  # the last step is whole once nothing more comes
    executor.shutdown()
    monitor.destroy_node()
    plant.destroy_node()
    np.testing.assert_allclose(
        [sample.time for sample in samples], PERIOD * np.arange(STEPS), atol=1e-9
    )
    for topic in TOPICS:
        np.testing.assert_array_equal(
            [sample.values[topic] for sample in samples], expected(topic), err_msg=topic
        )
