"""``flex_controller``: a PI joint-angle controller for the exodigit glove (an example package).

It answers every ``joint_states`` with one ``pressure_command`` computed from that state, which
is the lockstep protocol of a simulated glove and works as well on the wall clock:

    p = clip(kp·e + ki·∫e dt, 0, max_pressure),   e = target − q,

per joint, with dt from the states' stamps and the integral held while the command saturates.

Run: ``ros2 run my_glove_controller flex_controller --ros-args -r __ns:=/glove
-p targets:="[0.3, 0.3, 0.2]"``.
"""

from __future__ import annotations

import sys

import numpy as np
import rclpy
from rclpy.executors import ExternalShutdownException
from rclpy.node import Node
from sensor_msgs.msg import JointState
from std_msgs.msg import Float64MultiArray


class FlexLaw:
    """The control law, free of ROS (so a test can step it against a simulated glove).

    Parameters
    ----------
    targets : array_like, shape (3,)
        Desired joint angles (MCP, PIP, DIP), rad.
    kp : float
        Pa per rad of angle error.
    ki : float
        Pa per rad·s of integrated angle error.
    max_pressure : float
        Highest pressure commanded, Pa.
    """

    def __init__(self, targets, kp=5e4, ki=2e5, max_pressure=60e3) -> None:
        self.targets = np.asarray(targets, dtype=float)
        self.kp, self.ki, self.max_pressure = kp, ki, max_pressure
        self.integral = np.zeros(3)
        self.last_t: float | None = None

    def command(self, t: float, q) -> np.ndarray:
        """The pressures (Pa) answering a state at time ``t`` (s) with angles ``q`` (rad)."""
        error = self.targets - np.asarray(q, dtype=float)
        dt = 0.0 if self.last_t is None else max(t - self.last_t, 0.0)
        self.last_t = t
        integral = self.integral + error * dt
        raw = self.kp * error + self.ki * integral
        pressure = np.clip(raw, 0.0, self.max_pressure)
        self.integral = np.where(raw == pressure, integral, self.integral)  # anti-windup
        return pressure


class FlexController(Node):
    """The node: ``joint_states`` in, one ``pressure_command`` out per state."""

    def __init__(self) -> None:
        super().__init__('flex_controller')
        targets = self.declare_parameter('targets', [0.3, 0.3, 0.2]).value
        self.law = FlexLaw(
            targets,
            self.declare_parameter('kp', 5e4).value,
            self.declare_parameter('ki', 2e5).value,
        )
        self.create_subscription(JointState, 'joint_states', self.on_state, 10)
        self.publisher = self.create_publisher(Float64MultiArray, 'pressure_command', 10)

    def on_state(self, state: JointState) -> None:
        t = state.header.stamp.sec + state.header.stamp.nanosec * 1e-9
        pressure = self.law.command(t, state.position)
        self.publisher.publish(Float64MultiArray(data=pressure.tolist()))


def main(args=None) -> int:
    rclpy.init(args=args)
    node = FlexController()
    try:
        rclpy.spin(node)
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    finally:
        node.destroy_node()
        rclpy.try_shutdown()
    return 0


if __name__ == '__main__':
    sys.exit(main())
