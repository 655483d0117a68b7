"""A launch_testing example for ROS 2 installs: the flex controller in lockstep with the glove.

The launch description starts exodigit's ``plant`` in lockstep simulated time (as fast as the
CPU allows), paused, and this package's ``flex_controller`` with ``use_sim_time``. The test
subscribes to ``joint_states``, then lets simulated time run (``set_paused`` false); the plant
takes no step past 3 simulated seconds (``run_until``), and the test checks the angles of that
last state. (A plant started running waits for the controller, not for the test: the test would
join at whatever simulated time the glove had reached.) Run it in a sourced workspace, from this
package's directory, with::

    ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST launch_test test/glove_sim_launch.test.py

(It is named ``*.test.py`` so that plain pytest does not collect it: this package's pytest.ini
turns launch_testing's pytest plugin off, as pytest >= 9 refuses to load it.)
"""

import math
import time
import unittest

import launch
import launch_ros.actions
import launch_testing.actions
import launch_testing.asserts
import launch_testing.markers
import pytest
import rclpy
from sensor_msgs.msg import JointState
from std_srvs.srv import SetBool

NAMESPACE = '/launch_test_glove'
TARGETS = [0.3, 0.3, 0.2]  # rad
TOLERANCE = math.radians(1.0)
SIMULATED_SECONDS = 3.0
TIMEOUT = 60.0  # wall s


@pytest.mark.launch_test
@launch_testing.markers.keep_alive
def generate_test_description():
    plant = launch_ros.actions.Node(
        package='exodigit_nodes',
        executable='plant',
        namespace=NAMESPACE,
        parameters=[
            {
                'clock': 'sim',
                'lockstep': True,
                'real_time_factor': 0.0,
                'start_paused': True,
                'run_until': SIMULATED_SECONDS,
                'pressure_time_constant': 0.0,
            }
        ],
    )
    controller = launch_ros.actions.Node(
        package='my_glove_controller',
        executable='flex_controller',
        namespace=NAMESPACE,
        parameters=[{'use_sim_time': True, 'targets': TARGETS}],
    )
    description = launch.LaunchDescription(
        [plant, controller, launch_testing.actions.ReadyToTest()]
    )
    return description, {'plant': plant, 'controller': controller}


class TestTheControllerReachesItsTargets(unittest.TestCase):
    def test_angles_after_three_simulated_seconds(self):
        rclpy.init()
        node = rclpy.create_node('launch_test_listener')
        states = []
        subscription = node.create_subscription(
            JointState, f'{NAMESPACE}/joint_states', states.append, 1000
        )
        set_paused = node.create_client(SetBool, f'{NAMESPACE}/set_paused')
        try:
            deadline = time.monotonic() + TIMEOUT
            # Listen first, then start simulated time: the plant steps once the controller is up.
            while subscription.get_publisher_count() == 0 and time.monotonic() < deadline:
                rclpy.spin_once(node, timeout_sec=0.1)
            self.assertTrue(set_paused.wait_for_service(timeout_sec=TIMEOUT), 'no plant')
            resumed = set_paused.call_async(SetBool.Request(data=False))
            rclpy.spin_until_future_complete(node, resumed, timeout_sec=TIMEOUT)
            self.assertTrue(resumed.done() and resumed.result().success, 'plant did not resume')
            while time.monotonic() < deadline:
                rclpy.spin_once(node, timeout_sec=0.1)
                if states and stamp(states[-1]) >= SIMULATED_SECONDS:
                    break
            self.assertTrue(states, 'no joint_states received')
            # run_until held the plant there
            self.assertAlmostEqual(stamp(states[-1]), SIMULATED_SECONDS, places=6)
            for angle, target in zip(states[-1].position, TARGETS, strict=True):
                self.assertAlmostEqual(angle, target, delta=TOLERANCE)
        finally:
            node.destroy_node()
            rclpy.shutdown()


@launch_testing.post_shutdown_test()
class TestTheNodesExitCleanly(unittest.TestCase):
    def test_exit_codes(self, proc_info):
        launch_testing.asserts.assertExitCodes(proc_info)


def stamp(state):
    return state.header.stamp.sec + state.header.stamp.nanosec * 1e-9
