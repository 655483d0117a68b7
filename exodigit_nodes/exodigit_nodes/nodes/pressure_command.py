"""``pressure_command``: the glove's reference controller and command source.

A mode's controller (:func:`exodigit_model.control.mode_controller`) behind the
:class:`~exodigit_model.control.SafetyLimiter` publishes ``pressure_command``, or with
``output:=valves`` the ``valve_command`` of a :class:`~exodigit_model.control.ValveLoop` on
``chamber_pressure``; on a timer or, with ``lockstep``, one command per ``joint_states``.
docs/spec/ros.md: "Nodes and topics", "Safety behaviour", "Simulated time, faster than real time,
lockstep", "When time goes back", "Valves", "Trajectories".

Run: ``python -m exodigit_nodes.nodes.pressure_command --ros-args -p mode:=staircase``.
"""

from __future__ import annotations

import functools
from collections import Counter
from collections.abc import Callable
from typing import TYPE_CHECKING

import numpy as np
from diagnostic_msgs.msg import DiagnosticStatus
from exodigit_model.control import (
    CommandLoop,
    Controller,
    Feedback,
    PositionController,
    SafetyLimiter,
    SafetyLimits,
    Setpoint,
    ValveLoop,
    ValveLoopSettings,
    mode_controller,
)
from exodigit_model.stepping.settings import VENT
from rclpy.clock import JumpThreshold, TimeJump
from rclpy.duration import Duration
from std_msgs.msg import Float64MultiArray
from trajectory_msgs.msg import JointTrajectory

import exodigit_model

from ..logic.command_settings import LIMIT_NAMES, VALVE_NAMES, command_settings
from ..logic.inputs import (
    NANOSECONDS,
    InvalidInputError,
    joint_targets,
    joint_trajectory,
)
from .catalog import PRESSURE_COMMAND_NODE
from .command_inputs import CommandInputs
from .messages import (
    CHAMBER_PRESSURE,
    JOINT_STATES,
    JOINT_TARGETS,
    JOINT_TRAJECTORY,
    PRESSURE_COMMAND,
    VALVE_COMMAND,
    fill,
    joint_vector_message,
    valve_command_message,
)
from .node_base import LOG_THROTTLE, GloveNode, load_model_params
from .process import run
from .qos import READER_QOS, STREAM_QOS

if TYPE_CHECKING:
    from exodigit_model import GloveModel

BACKWARDS = JumpThreshold(
    min_forward=None, min_backward=Duration(nanoseconds=-1), on_clock_change=False
)
"""Any jump of the node clock back in time (forward jumps are simulated time running fast)."""


class PressureCommand(GloveNode):
    """The command node: wires ROS to a controller and :class:`.SafetyLimiter`."""

    executable = PRESSURE_COMMAND_NODE.executable
    table = PRESSURE_COMMAND_NODE.table

    def __init__(self, **node_options) -> None:
        super().__init__(**node_options)
        self.params = load_model_params(self.values['params_file'])
        _, valve_loop = self.settings
        rate = self.values['rate_hz']
        self.period_ns = round(NANOSECONDS / rate)
        self.joint_target = np.array(self.values['joint_targets'])
        """The position mode's latest target, rad (the parameter's until a command)."""
        self.setpoint = Setpoint(self.joint_target)
        self.limit_counts: Counter[str] = Counter()
        self.last_back_off = ''
        self.back_offs_reported = 0
        self.valves = self.values['output'] == 'valves'
        self.safe = VENT if self.valves else np.zeros(3)
        """What it sends on exit: a vent (valves) or zero pressure."""
        self.sent = self.safe
        self.target = np.zeros(3)
        self.valve_loop = ValveLoop(valve_loop)
        self.lockstep = self.values['lockstep']
        self.last_tick: int | None = None
        # Subscriptions before the publisher: the plant then sees our joint_states reader first.
        self.inputs = CommandInputs(self)
        self.start_over(self.get_clock().now().nanoseconds)
        if not self.lockstep:  # in lockstep the stamps are the time (answer)
            self.time_jumps = self.get_clock().create_jump_callback(
                BACKWARDS, post_callback=self.on_time_jump
            )
        self.command_message = valve_command_message() if self.valves else joint_vector_message()
        for kind, topic, parse in (
            (Float64MultiArray, JOINT_TARGETS, joint_targets),
            (JointTrajectory, JOINT_TRAJECTORY, joint_trajectory),
        ):
            on_targets = functools.partial(self.on_targets, topic, parse)
            self.create_subscription(kind, topic, on_targets, READER_QOS)
        self.topic = VALVE_COMMAND if self.valves else PRESSURE_COMMAND
        self.publisher = self.create_publisher(Float64MultiArray, self.topic, STREAM_QOS)
        if not self.lockstep:
            self.create_timer(1.0 / rate, self.tick)
        self.create_timer(self.values['diagnostic_period'], self.report)
        pace = 'in lockstep with joint_states' if self.lockstep else f'at {rate:g} Hz'
        self.get_logger().info(
            f'pressure_command: mode {self.values["mode"]} {pace}, '
            f'max {self.values["max_pressure"]:g} Pa, {self.values["max_pressure_rate"]:g} Pa/s, '
            f'publishing {self.topic}'
        )

    make_settings = staticmethod(command_settings)

    def apply(self, settings: tuple[SafetyLimits, ValveLoopSettings], changed: set[str]) -> None:
        """New limits and valve loop at once; a new controller (session restarts) when its own."""
        self.loop.limiter.limits, valve_loop = settings
        self.valve_loop.configure(valve_loop)
        if changed - LIMIT_NAMES - VALVE_NAMES:
            if 'joint_targets' in changed:
                self.joint_target = np.array(self.values['joint_targets'])
                self.setpoint.hold(self.joint_target)
            self.loop.controller = self.make_controller()
            self.started = None if self.lockstep else self.get_clock().now().nanoseconds

    @functools.cached_property
    def model(self) -> GloveModel:
        """The feed-forward's model, built when ``position`` or ``force`` first needs it.

        A node in another mode loads no kernel: half its start-up CPU (docs/compiled.md).
        """
        return exodigit_model.GloveModel(self.params)

    def make_controller(self) -> Controller:
        """The controller of the current mode (the position mode at the latest target)."""
        values = self.values
        return mode_controller(values['mode'], values, lambda: self.model, self.joint_target)

    # -- sessions --------------------------------------------------------------------------

    def now_ns(self) -> int:
        """The node's time, ns: in lockstep the last state answered (before one, the clock)."""
        if self.lockstep and self.last_tick is not None:
            return self.last_tick
        return self.get_clock().now().nanoseconds

    def start_over(self, now: int) -> None:
        """A new session from ``now`` (ns): a new controller, limiter and valve loop.

        Kept: the parameters, the latest targets (the setpoint restarts) and the diagnostics'
        counts; :meth:`.CommandInputs.forget` says what of the inputs goes.
        """
        limits, _ = self.settings
        self.setpoint.restart(self.joint_target, now)
        self.loop = CommandLoop(self.make_controller(), SafetyLimiter(limits))
        self.started = None if self.lockstep else now
        self.last_tick = None
        self.inputs.forget()
        self.valve_loop.reset()

    def on_time_jump(self, jump: TimeJump) -> None:
        """The node clock went back (a new session): start over."""
        self.start_over(self.get_clock().now().nanoseconds)
        self.get_logger().info(
            f'time went back {-jump.delta.nanoseconds * 1e-9:g} s: a new session, started over'
        )

    # -- targets ---------------------------------------------------------------------------

    def on_targets(
        self, topic: str, parse: Callable, message: Float64MultiArray | JointTrajectory
    ) -> None:
        """New position targets (rad) from a ``joint_targets`` or ``joint_trajectory``.

        ``parse(message, lower, upper)`` gives the trajectory and its start (ns; None: now).
        """
        limits = self.loop.limiter.limits
        try:
            trajectory, start = parse(message, limits.joint_lower, limits.joint_upper)
        except InvalidInputError as error:
            self.reject(topic, error)
            return
        self.setpoint.place(trajectory, start, self.now_ns())

    # -- the loop --------------------------------------------------------------------------

    def tick(self) -> None:
        """Timer: compute, limit and publish one command from the freshest feedback."""
        now = self.get_clock().now().nanoseconds
        # Never more than one period (the rate limit stays a limit when a tick runs late),
        # never negative (a clock set back).
        elapsed = self.period_ns if self.last_tick is None else now - self.last_tick
        dt = min(max(elapsed, 0), self.period_ns) / NANOSECONDS
        self.last_tick = now
        seconds, inputs = now / NANOSECONDS, self.inputs
        angles, forces = inputs.fresh(inputs.angles, seconds), inputs.fresh(inputs.forces, seconds)
        self.command(now, dt, Feedback(angles, forces), inputs.fresh(inputs.pressure, seconds))

    def answer(
        self,
        stamp: int,
        angles: np.ndarray,
        forces: np.ndarray | None,
        pressure: np.ndarray | None,
    ) -> None:
        """Lockstep: one command for a complete state stamped ``stamp`` (ns), its time.

        A stamp before the last one answered starts a new session. dt is the step between two
        stamps (the node's period for a session's first state).
        """
        if self.last_tick is not None and stamp < self.last_tick:
            self.start_over(stamp)  # time went back: a new session, from this state
            self.get_logger().info(f'{JOINT_STATES} went back to t = {stamp} ns: a new session')
        if self.started is None:
            self.started = stamp
        elapsed = self.period_ns if self.last_tick is None else stamp - self.last_tick
        self.last_tick = stamp
        self.command(stamp, elapsed / NANOSECONDS, Feedback(angles, forces), pressure)

    def command(
        self, now: int, dt: float, feedback: Feedback, measured: np.ndarray | None
    ) -> None:
        """Compute, limit and publish the command at ``now`` (ns) after ``dt`` (s).

        The position mode aims at the setpoint at ``now`` + one period, when the step the
        command drives ends. With valves the limited pressures are the loop's targets and
        ``measured`` the chamber pressures (Pa) it closes on: None (none fresh) vents.
        """
        target = self.setpoint.at(now + self.period_ns)
        if not np.array_equal(target, self.joint_target):
            self.joint_target = target
            if isinstance(self.loop.controller, PositionController):
                self.loop.controller.set_targets(target)
        result = self.loop.command((now - self.started) / NANOSECONDS, dt, feedback)
        if result.missing:
            self.get_logger().warning(
                f'{self.values["mode"]} mode: no fresh feedback for over '
                f'{self.values["feedback_timeout"]:g} s: ramping down to zero',
                throttle_duration_sec=LOG_THROTTLE,
            )
        self.limit_counts.update(result.reasons.keys())
        if 'back-off' in result.reasons:
            self.last_back_off = result.reasons['back-off']
        if 'back-off' in result.reasons or 'non-finite' in result.reasons:
            self.get_logger().warning(
                '; '.join(result.reasons.values()), throttle_duration_sec=LOG_THROTTLE
            )
        self.target = result.pressure
        if not self.valves:
            self.sent = result.pressure
        elif measured is None:
            self.get_logger().warning(
                f'no fresh {CHAMBER_PRESSURE} for over {self.values["feedback_timeout"]:g} s: '
                'venting',
                throttle_duration_sec=LOG_THROTTLE,
            )
            self.sent = VENT
        else:
            self.sent = self.valve_loop.openings(result.pressure, measured, dt)
        self.publisher.publish(fill(self.command_message, self.sent))

    def on_shutdown(self) -> None:
        """Send zero pressure (a vent); the process then waits until subscribers have it."""
        self.sent = self.safe
        self.publisher.publish(fill(self.command_message, self.sent))
        self.get_logger().info('stopping: sent ' + ('a vent' if self.valves else 'zero pressure'))

    def report(self) -> None:
        """One /diagnostics status: mode, command, limits acting, feedback age."""
        now, inputs = self.now_seconds(), self.inputs
        problems = []
        if inputs.fresh(inputs.angles, now) is None:
            problems.append(f'no fresh {JOINT_STATES} (is the plant running?)')
        backed_off = self.limit_counts['back-off'] - self.back_offs_reported
        if backed_off:
            problems.append(f'{backed_off} steps {self.last_back_off}')
            self.back_offs_reported += backed_off
        if self.valves and inputs.fresh(inputs.pressure, now) is None:
            problems.append(f'no fresh {CHAMBER_PRESSURE}: venting')
        sent = 'valve command sent (in, then out)' if self.valves else 'command sent (Pa)'
        values = {
            'mode': self.values['mode'],
            sent: str(self.sent.tolist()),
            'pressure target (Pa)': str(self.target.tolist()),
            'joint_states age (s)': 'none'
            if inputs.angles is None
            else f'{now - inputs.angles[0]:.3f}',
            **{f'limited steps: {kind}': str(n) for kind, n in self.limit_counts.items()},
        }
        level = DiagnosticStatus.WARN if problems else DiagnosticStatus.OK
        self.publish_status(level, '; '.join(problems) or 'running', values)


def main(args: list[str] | None = None) -> int:
    """Console script ``pressure_command`` (``ros2 run exodigit_nodes pressure_command``)."""
    return run(PressureCommand, args)


if __name__ == '__main__':
    raise SystemExit(main())
