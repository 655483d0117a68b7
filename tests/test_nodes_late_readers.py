"""A recording reader that matches a publisher late still gets what it sent before.

Discovery is per pair of processes and took up to 3 s on a loaded machine, while a plant in
simulated time stepped on: a hand's bag once held no step of a plant (fresh clone fc54). The
glove's publishers keep their last 1,000 samples for late readers (transient-local), and the
bag recorder and the runner's monitor read the plant's topics that way. Here the plant's
samples are all sent before the reader exists, so a reader that gets only what is sent after
it matched gets none.
"""

import os

import numpy as np
import pytest
import rclpy
from builtin_interfaces.msg import Time
from exodigit_model.tools.bag import read_bag
from exodigit_nodes.nodes.qos import WRITER_DEPTH, WRITER_QOS
from exodigit_nodes.nodes.recorder import Recorder
from exodigit_nodes.runner.monitor import GloveMonitor
from exodigit_nodes.runner.summary import GloveSignals
from rclpy.executors import SingleThreadedExecutor
from ros_harness import DISCOVERY_TIMEOUT, wait_until
from sensor_msgs.msg import JointState
from std_msgs.msg import Float64MultiArray

NAMESPACE = f'/late_readers_{os.getpid()}'
STEPS = 300
"""Steps sent before the reader exists (fewer than the publishers keep: WRITER_DEPTH)."""


@pytest.fixture
def context(ros_domain):
    context = rclpy.Context()
    rclpy.init(context=context, domain_id=ros_domain)
    yield context
    rclpy.try_shutdown(context=context)


def sent_steps(context, namespace):
    """A stand-in plant that has sent STEPS steps before anyone listens.

    Each step as the plant sends it: pressure, then angles (stamped at 100 Hz), then forces;
    step k's values are all k times a unit, so a sample shows its step.
    """
    plant = rclpy.create_node('plant', namespace=namespace, context=context)
    pressure = plant.create_publisher(Float64MultiArray, 'chamber_pressure', WRITER_QOS)
    angles = plant.create_publisher(JointState, 'joint_states', WRITER_QOS)
    forces = plant.create_publisher(Float64MultiArray, 'contact_forces', WRITER_QOS)
    for step in range(STEPS):
        pressure.publish(Float64MultiArray(data=[1e3 * step] * 3))
        state = JointState(name=['mcp', 'pip', 'dip'], position=[1e-3 * step] * 3)
        state.header.stamp = Time(nanosec=10_000_000 * (step % 100), sec=step // 100)
        angles.publish(state)
        forces.publish(Float64MultiArray(data=[0.01 * step] * 3))
    return plant


def test_the_publishers_keep_more_than_a_test_sends():
    assert WRITER_DEPTH > STEPS


def test_a_recorder_that_matches_late_records_every_step_sent_before(context, tmp_path):
    namespace = f'{NAMESPACE}_bag'
    plant = sent_steps(context, namespace)
    recorder = Recorder(tmp_path / 'bag', context=context, namespace=namespace)
    executor = SingleThreadedExecutor(context=context)
    executor.add_node(recorder)

    def recorded():
        executor.spin_once(timeout_sec=0.01)
        return recorder.taken() >= 3 * STEPS

    assert wait_until(recorded, DISCOVERY_TIMEOUT), recorder.taken()
    recorder.close()
    bag = read_bag(tmp_path / 'bag')
    for topic, unit in (
        ('chamber_pressure', 1e3),
        ('joint_states', 1e-3),
        ('contact_forces', 0.01),
    ):
        np.testing.assert_allclose(
            bag[topic].values, unit * np.arange(STEPS)[:, None] * np.ones(3), err_msg=topic
        )
    executor.shutdown()
    recorder.destroy_node()
    plant.destroy_node()


def test_a_monitor_that_matches_late_takes_every_step_sent_before(context):
    namespace = f'{NAMESPACE}_monitor'
    plant = sent_steps(context, namespace)
    samples = []
    signals = GloveSignals(['plant'])
    monitor = GloveMonitor(signals, namespace, samples.append, context=context)
    executor = SingleThreadedExecutor(context=context)
    executor.add_node(monitor)

    def taken():
        executor.spin_once(timeout_sec=0.01)
        return monitor.taken >= 3 * STEPS

    assert wait_until(taken, DISCOVERY_TIMEOUT), monitor.taken
    samples.extend(signals.flush())  # the last step is whole once nothing more comes
    steps = np.arange(STEPS)
    np.testing.assert_allclose([sample.time for sample in samples], 0.01 * steps, atol=1e-9)
    for signal, unit in (
        ('chamber_pressure', 1e3),
        ('joint_states', 1e-3),
        ('contact_forces', 0.01),
    ):
        np.testing.assert_allclose(
            [sample.values[signal] for sample in samples],
            unit * steps[:, None] * np.ones(3),
            err_msg=signal,
        )
    executor.shutdown()
    monitor.destroy_node()
    plant.destroy_node()
