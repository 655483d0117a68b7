"""A late subscriber gets the glove as it is now, not a replay (docs/spec/ros.md, "QoS").

``ros2 topic echo`` (and RViz, Foxglove, any node that adapts to the publishers) subscribes
transient-local when every publisher of a topic offers it, and then receives the publishers'
kept history first. When every glove publisher kept 1,000 samples that way, ``ros2 topic echo
--once chamber_pressure`` printed ``[0.0, 0.0, 0.0]`` while the chambers held 20/30/40 kPa.
Streams are volatile now; only the plant's ``applied_command`` keeps its history, the record of
what drove the glove (tests/test_nodes_applied_command.py).
"""

import numpy as np
import pytest
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
from ros_harness import DISCOVERY_TIMEOUT, wait_until
from sensor_msgs.msg import JointState
from std_msgs.msg import Float64MultiArray

NS = '/late_readers'
COMMAND = [20e3, 30e3, 40e3]
"""Pa: what the chambers hold by the time the late subscriber comes."""
TOLERANCE = 1.0
"""Pa: an ideal regulator holds the command exactly; sensor noise is off."""


def echo_profile(probe, topic: str) -> QoSProfile:
    """The profile ``ros2 topic echo`` subscribes ``topic`` with (ros2topic's QoS choice).

    Transient-local and reliable where every publisher of the topic offers it, else volatile and
    best effort; depth 10.
    """
    offered = [info.qos_profile for info in probe.node.get_publishers_info_by_topic(topic)]
    assert offered, f'no publisher of {topic}'
    latched = all(q.durability == DurabilityPolicy.TRANSIENT_LOCAL for q in offered)
    reliable = all(q.reliability == ReliabilityPolicy.RELIABLE for q in offered)
    return QoSProfile(
        depth=10,
        durability=DurabilityPolicy.TRANSIENT_LOCAL if latched else DurabilityPolicy.VOLATILE,
        reliability=ReliabilityPolicy.RELIABLE if reliable else ReliabilityPolicy.BEST_EFFORT,
    )


@pytest.fixture(scope='module')
def holding_glove(launcher, probe):
    """A plant whose chambers hold COMMAND, reached well after its first steps."""
    plant = launcher.start(
        'plant',
        {'rate_hz': 100.0, 'command_timeout': 60.0, 'pressure_time_constant': 0.0},
        namespace=NS,
    )
    pressures = probe.subscribe(f'{NS}/chamber_pressure', Float64MultiArray)
    assert pressures.wait_count(1, timeout=DISCOVERY_TIMEOUT), plant.stderr()
    probe.publisher(f'{NS}/pressure_command', Float64MultiArray).publish(
        Float64MultiArray(data=COMMAND)
    )
    held = pressures.wait_for(
        lambda m: np.allclose(m.data, COMMAND, atol=TOLERANCE), DISCOVERY_TIMEOUT
    )
    assert held is not None, pressures.latest()
    return probe


@pytest.mark.parametrize(
    ('topic', 'message_type', 'value'),
    [
        ('chamber_pressure', Float64MultiArray, lambda m: m.data),
        ('joint_states', JointState, None),
    ],
)
def test_echo_once_prints_what_the_glove_holds_now(holding_glove, topic, message_type, value):
    probe = holding_glove
    name = f'{NS}/{topic}'
    profile = echo_profile(probe, name)
    assert profile.durability == DurabilityPolicy.VOLATILE  # what the glove's streams offer
    echo = probe.subscribe(name, message_type, qos=profile)
    assert echo.wait_count(1, timeout=DISCOVERY_TIMEOUT)
    first = echo.messages()[0]
    if value is not None:  # the first message is of the chambers now, not of the start
        np.testing.assert_allclose(value(first), COMMAND, atol=TOLERANCE)
    else:  # the first state is a current one: the flexed finger, not the rest state
        assert max(first.position) > 0.05


def test_the_record_of_commands_is_latched_for_a_late_reader(holding_glove):
    probe = holding_glove
    name = f'{NS}/applied_command'
    profile = echo_profile(probe, name)
    assert profile.durability == DurabilityPolicy.TRANSIENT_LOCAL
    echo = probe.subscribe(name, Float64MultiArray, qos=profile)
    assert wait_until(lambda: echo.count() >= 2, DISCOVERY_TIMEOUT), echo.count()
    # the whole record: the vent the plant started with, then the one command it took
    assert [list(m.data) for m in echo.messages()] == [[0.0, 0.0, 0.0], COMMAND]
