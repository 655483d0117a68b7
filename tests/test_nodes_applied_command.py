"""The plant's record of the commands it took, ``applied_command`` (docs/spec/ros.md, topics).

A volatile controller's commands reach only the readers its writer has matched when it sends
them, and a writer can match a reader after that reader has matched the writer: a reader
counting the controller's commands can miss the first ones however long it waited for its own
match (a CI run's testing kit heard none of 20 answers the plant had taken). The plant answers
each command on ``applied_command`` (after the vent it starts with), transient-local: a reader
that matches late gets all of it.
Here the loss is made certain (the readers are created after the commands were sent) and the
record is checked to have every command, in order, as the plant took it.
"""

import numpy as np
from exodigit_nodes.nodes.qos import record_profile
from rclpy.duration import Duration
from ros_harness import DISCOVERY_TIMEOUT, wait_until
from sensor_msgs.msg import JointState
from std_msgs.msg import Float64MultiArray

NS = '/applied_command'
#: Distinct commands, Pa, each with one refused command (NaN) after it: eight messages sent at
#: once, within the plant's reader depth of 10, so the plant takes every one.
COMMANDS = [[1e3 * k, 2e3 * k, 3e3 * k] for k in range(1, 5)]


def test_a_reader_that_matches_late_gets_every_command_the_plant_took(launcher, probe):
    launcher.start('plant', {'rate_hz': 50.0, 'command_timeout': 60.0}, namespace=NS)
    states = probe.subscribe(f'{NS}/joint_states', JointState)
    assert states.wait_count(1, timeout=DISCOVERY_TIMEOUT)
    publisher = probe.publisher(f'{NS}/pressure_command', Float64MultiArray)
    for command in COMMANDS:
        publisher.publish(Float64MultiArray(data=command))
        publisher.publish(Float64MultiArray(data=[float('nan')] * 3))
    # every command sent is in the plant's reader once it has acknowledged them all
    assert publisher.wait_for_all_acked(Duration(seconds=DISCOVERY_TIMEOUT))

    sent = probe.subscribe(f'{NS}/pressure_command', Float64MultiArray)  # volatile, late
    applied = probe.subscribe(
        f'{NS}/applied_command', Float64MultiArray, qos=record_profile('applied_command')
    )
    assert wait_until(lambda: applied.count() >= 1 + 2 * len(COMMANDS), DISCOVERY_TIMEOUT), (
        f'{applied.count()} of {1 + 2 * len(COMMANDS)} applied commands'
    )
    assert sent.matched()
    assert sent.count() == 0  # what a late reader of the commands themselves gets

    # the vent of a plant that has had no command yet, then each command: a refused one
    # leaves the one before it in force
    expected = [[0.0, 0.0, 0.0], *np.repeat(COMMANDS, 2, axis=0)]
    np.testing.assert_array_equal([m.data for m in applied.messages()], expected)
