"""A controller node for the lockstep tests: answers each joint_states with one command.

The command is a function of the state's stamp only, p(t) = PEAK·(1 − cos 2πt/PERIOD)/2 on all
chambers, so a test can replay the session in process. With ``--delay S`` it sleeps S wall
seconds before each answer (a slow controller); with ``--stall-after N`` it answers the first
N states only (a controller that hangs); with ``--no-parameters`` it serves no parameters
(it cannot answer the plant's handshake).

Run: ``python lockstep_controller.py [--delay S] [--stall-after N] --ros-args -r __ns:=/ns``.
"""

import argparse
import math
import sys
import time

import rclpy
from rclpy.executors import ExternalShutdownException
from rclpy.node import Node
from sensor_msgs.msg import JointState
from std_msgs.msg import Float64MultiArray

PEAK = 40e3  # Pa
PERIOD = 1.0  # s


def command_at(t: float) -> list[float]:
    """The command answering a state stamped ``t`` (s), Pa."""
    return [PEAK * 0.5 * (1.0 - math.cos(2.0 * math.pi * t / PERIOD))] * 3


class Controller(Node):
    def __init__(self, delay: float, stall_after: int | None, parameters: bool) -> None:
        super().__init__('lockstep_controller', start_parameter_services=parameters)
        self.delay = delay
        self.answers_left = stall_after
        self.create_subscription(JointState, 'joint_states', self.answer, 1000)
        self.publisher = self.create_publisher(Float64MultiArray, 'pressure_command', 10)

    def answer(self, state: JointState) -> None:
        if self.answers_left is not None:
            if self.answers_left == 0:
                return
            self.answers_left -= 1
        if self.delay:
            time.sleep(self.delay)
        t = (state.header.stamp.sec * 10**9 + state.header.stamp.nanosec) / 1e9
        self.publisher.publish(Float64MultiArray(data=command_at(t)))


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument('--delay', type=float, default=0.0)
    parser.add_argument('--stall-after', type=int, default=None)
    parser.add_argument('--no-parameters', action='store_true')
    args, ros_args = parser.parse_known_args()
    rclpy.init(args=[sys.argv[0], *ros_args])
    node = Controller(args.delay, args.stall_after, not args.no_parameters)
    try:
        rclpy.spin(node)
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    finally:
        node.destroy_node()
        rclpy.try_shutdown()


if __name__ == '__main__':
    main()
