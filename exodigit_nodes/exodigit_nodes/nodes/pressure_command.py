"""``pressure_command``: the glove's reference controller and command source (docs/spec/ros.md).

Modes: ``staircase`` (0 → 50 kPa in 10 kPa steps and back, as in the paper's experiments), ``sine``
(continuous passive motion between two pressures), ``hold``, ``position`` (feed-forward
``GloveModel.pressure_for`` plus PI on ``joint_states``; targets from the ``joint_targets``
parameter or topic) and ``force`` (target contact forces with PI on
``estimated_contact_forces``). Every command passes the safety limiter: within [0, max_pressure],
no faster than max_pressure_rate, ramping down when a joint leaves its range of motion or a
contact force exceeds max_contact_force. On exit (Ctrl-C, SIGTERM) it publishes zero pressure.

With ``output:=valves`` (for a plant with ``actuation:=valves``, docs/spec/model.md §14) the
limited pressures are the targets of a pressure loop on the measured ``chamber_pressure``
(:class:`exodigit_model.control.ValveLoop`, the loop of in-process trials too), and it publishes
that loop's ``valve_command`` (six openings) instead: with no fresh ``chamber_pressure`` and on
exit, a vent (inlets closed, outlets open).

It commands at ``rate_hz`` on its own timer, or, with ``lockstep:=true`` (the plant in lockstep
simulated time, docs/spec/ros.md Part II), answers each ``joint_states`` with one command computed
from that state and its stamp (in ``force`` mode: from that state and the estimate stamped with
the same stamp; with valves: from that state and the ``chamber_pressure`` of the same step,
paired by the times they were sent as the estimator pairs them).

When its time goes back (a plant's ``reset_simulation``: a new session, e.g. the next patient of
a trial), it starts over as if just started: no integral, no rate limit carried over, no feedback
or lockstep state of the old session; its parameters and latest ``joint_targets`` stay. Its time is
the node clock (``/clock`` with ``use_sim_time``: a time-jump callback, the signal tf2's buffers
clear on), in lockstep the stamps of the states it answers (a state stamped before the last one
answered). A session's time (what ``staircase`` and ``sine`` follow) starts when the node starts
or starts over, in lockstep at the first state it answers, as an in-process trial's at its first
command.

Run: ``python -m exodigit_nodes.nodes.pressure_command --ros-args -p mode:=staircase``.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np
from diagnostic_msgs.msg import DiagnosticStatus
from exodigit_model.control import (
    LOOP_PARAMETERS,
    CommandLoop,
    Controller,
    Feedback,
    ForceController,
    Hold,
    PositionController,
    SafetyLimiter,
    SafetyLimits,
    Sine,
    Staircase,
    ValveLoop,
    ValveLoopSettings,
)
from exodigit_model.stepping.joining import STEP_TOLERANCE
from exodigit_model.stepping.settings import VENT
from rclpy.clock import Clock, ClockType, JumpThreshold, TimeJump
from rclpy.duration import Duration
from sensor_msgs.msg import JointState
from std_msgs.msg import Float64MultiArray

import exodigit_model

from ..logic.estimation import Pair, SamplePairer
from ..logic.inputs import (
    InvalidInputError,
    joint_positions,
    joint_vector,
    sent_seconds,
    stamp_age,
    stamp_seconds,
)
from .catalog import PRESSURE_COMMAND_NODE
from .message_info import WithInfo
from .messages import (
    CHAMBER_PRESSURE,
    ESTIMATED_CONTACT_FORCES,
    JOINT_STATES,
    JOINT_TARGETS,
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

MAX_FORCE_READING = 1e3
"""Largest |estimated contact force| accepted as a measurement, N."""
ESTIMATOR_POLL = 0.05
"""Lockstep force mode: wall seconds between two looks for the estimator's publisher."""
BACKWARDS = JumpThreshold(
    min_forward=None, min_backward=Duration(nanoseconds=-1), on_clock_change=False
)
"""Any jump of the node clock back in time (forward jumps are simulated time running fast)."""

LIMIT_NAMES = frozenset(
    {
        'max_pressure',
        'max_pressure_rate',
        'joint_lower_limits',
        'joint_upper_limits',
        'max_contact_force',
        'feedback_timeout',
    }
)
VALVE_NAMES = frozenset(LOOP_PARAMETERS)
"""The valve loop's parameters (:class:`exodigit_model.control.ValveLoopSettings`' fields)."""


def safety_limits(values: dict[str, Any]) -> SafetyLimits:
    """The safety limits of a set of pressure_command parameter values."""
    return SafetyLimits(
        max_pressure=values['max_pressure'],
        max_pressure_rate=values['max_pressure_rate'],
        joint_lower=values['joint_lower_limits'],
        joint_upper=values['joint_upper_limits'],
        max_contact_force=values['max_contact_force'],
    )


@dataclass(frozen=True)
class CommandSettings:
    """The command node's settings: its parameter values, the safety limits and valve loop."""

    values: dict[str, Any]
    limits: SafetyLimits
    valve_loop: ValveLoopSettings


class PressureCommand(GloveNode):
    """The command node: wires ROS to a controller and :class:`.SafetyLimiter`."""

    executable = PRESSURE_COMMAND_NODE.executable
    table = PRESSURE_COMMAND_NODE.table

    def __init__(self, **node_options) -> None:
        super().__init__(**node_options)
        self.params = load_model_params(self.values['params_file'])
        self.period = 1.0 / self.values['rate_hz']
        self.topic_targets: np.ndarray | None = None
        self.limit_counts: dict[str, int] = {}
        self.last_back_off = ''
        self.back_offs_reported = 0
        self.valves = self.values['output'] == 'valves'
        self.safe = VENT if self.valves else np.zeros(3)
        """What it sends on exit: a vent (valves) or zero pressure."""
        self.sent = self.safe
        self.target = np.zeros(3)
        self.valve_loop = ValveLoop(self.settings.valve_loop)
        self.lockstep = self.values['lockstep']
        self.pressure: tuple[float, np.ndarray] | None = None
        self.pairer = SamplePairer(STEP_TOLERANCE) if self.valves and self.lockstep else None
        """Lockstep valves: pairs each state with its step's chamber_pressure."""
        self.pending: dict[str, Any] = {'angles': None, 'forces': None, 'pressure': None}
        self.start_over(self.session_start())
        if not self.lockstep:  # in lockstep the stamps are the time (on_joint_states)
            self.time_jumps = self.get_clock().create_jump_callback(
                BACKWARDS, post_callback=self.on_time_jump
            )

        self.command_message = valve_command_message() if self.valves else joint_vector_message()
        # Subscriptions before the publisher: when the plant sees our commands' publisher, it
        # has (practically always) seen our joint_states subscription announced first.
        if self.valves:
            self.create_subscription(
                Float64MultiArray, CHAMBER_PRESSURE, WithInfo(self.on_pressure), READER_QOS
            )
        self.forces_subscription = self.create_subscription(
            JointState, ESTIMATED_CONTACT_FORCES, self.on_forces, READER_QOS
        )
        self.estimator_timer = None
        if self.lockstep and self.values['mode'] == 'force':
            # An answer needs the estimate of the state: listen for states (and so count as a
            # lockstep controller of the plant) once the estimator's publisher is matched, or
            # the estimate of the first state could be sent before we can hear it.
            self.estimator_timer = self.create_timer(
                ESTIMATOR_POLL,
                self.listen_once_estimated,
                clock=Clock(clock_type=ClockType.STEADY_TIME),
            )
            self.get_logger().info(
                f'lockstep force mode: answering {JOINT_STATES} once an estimator on '
                f'{ESTIMATED_CONTACT_FORCES} is matched'
            )
        else:
            self.listen_to_states()
        self.create_subscription(Float64MultiArray, JOINT_TARGETS, self.on_targets, READER_QOS)
        self.topic = VALVE_COMMAND if self.valves else PRESSURE_COMMAND
        self.publisher = self.create_publisher(Float64MultiArray, self.topic, STREAM_QOS)
        if not self.lockstep:
            self.create_timer(self.period, self.tick)
        self.create_timer(self.values['diagnostic_period'], self.report)
        pace = 'in lockstep with joint_states' if self.lockstep else f'at {self.period**-1:g} Hz'
        self.get_logger().info(
            f'pressure_command: mode {self.values["mode"]} {pace}, '
            f'max {self.values["max_pressure"]:g} Pa, {self.values["max_pressure_rate"]:g} Pa/s, '
            f'publishing {self.topic}'
        )

    # -- parameters ------------------------------------------------------------------------

    def make_settings(self, values) -> CommandSettings:
        """Check the parameters together (ValueError naming the parameter)."""
        if values['sine_low'] > values['sine_high']:
            raise ValueError(
                f'sine_low ({values["sine_low"]:g} Pa) must not exceed sine_high '
                f'({values["sine_high"]:g} Pa)'
            )
        if values['staircase_peak'] < values['staircase_step']:
            raise ValueError(
                f'staircase_peak ({values["staircase_peak"]:g} Pa) must be at least '
                f'staircase_step ({values["staircase_step"]:g} Pa)'
            )
        limits = safety_limits(values)
        targets = np.array(values['joint_targets'])
        if ((targets < limits.joint_lower) | (targets > limits.joint_upper)).any():
            raise ValueError(
                f'joint_targets {list(values["joint_targets"])} rad must lie inside '
                'joint_lower_limits .. joint_upper_limits'
            )
        valve_loop = ValveLoopSettings(**{name: values[name] for name in VALVE_NAMES})
        return CommandSettings(values, limits, valve_loop)

    def apply(self, settings: CommandSettings, changed: set[str]) -> None:
        """New limits and valve loop at once; a new controller (session restarts) when its own."""
        self.loop.limiter.limits = settings.limits
        self.valve_loop.configure(settings.valve_loop)
        if changed - LIMIT_NAMES - VALVE_NAMES:
            if 'joint_targets' in changed:
                self.topic_targets = None
            self.loop.controller = self.make_controller()
            self.started = self.session_start()

    @functools.cached_property
    def model(self) -> GloveModel:
        """The feed-forward's model, built when a controller first needs it.

        Only ``position`` and ``force`` do: a node in another mode never imports numba nor
        loads a kernel, half its start-up CPU (docs/compiled.md).
        """
        return exodigit_model.GloveModel(self.params)

    def make_controller(self) -> Controller:
        """The controller of the current mode."""
        v = self.values
        mode = v['mode']
        if mode == 'staircase':
            return Staircase(v['staircase_step'], v['staircase_peak'], v['step_duration'])
        if mode == 'sine':
            return Sine(v['sine_low'], v['sine_high'], v['sine_period'])
        if mode == 'hold':
            return Hold(np.array(v['hold_pressure']))
        if mode == 'position':
            targets = v['joint_targets'] if self.topic_targets is None else self.topic_targets
            return PositionController(self.model, targets, v['position_kp'], v['position_ki'])
        return ForceController(self.model, v['force_targets'], v['force_kp'], v['force_ki'])

    # -- sessions --------------------------------------------------------------------------

    def session_start(self) -> float | None:
        """When a session begun now starts: now (s), or in lockstep None (its first state)."""
        return None if self.lockstep else self.now_seconds()

    def start_over(self, now: float | None) -> None:
        """A new session from ``now`` (s; None: its first state): forget the last one's state.

        At start, and when time goes back (module text). Kept: the parameters, the latest
        ``joint_targets`` (what the node is told to do) and the diagnostics' counts. A state
        waiting for its estimate (lockstep force mode) is forgotten; an estimate waiting is kept:
        it may be the new session's, come before its state (an older one never pairs with a
        state of the new session: pairing is by stamp).
        """
        self.loop = CommandLoop(self.make_controller(), SafetyLimiter(self.settings.limits))
        self.started = now
        self.last_tick: float | None = None
        self.angles: tuple[float, np.ndarray] | None = None
        self.forces: tuple[float, np.ndarray] | None = None
        self.pending['angles'] = self.pending['pressure'] = None
        self.valve_loop.reset()

    def on_time_jump(self, jump: TimeJump) -> None:
        """The node clock went back (``/clock`` jumped back: a new session): start over."""
        self.start_over(self.session_start())
        self.get_logger().info(
            f'time went back {-jump.delta.nanoseconds * 1e-9:g} s: a new session, started over'
        )

    # -- inputs ----------------------------------------------------------------------------

    def listen_to_states(self) -> None:
        """Subscribe ``joint_states`` (the state each command answers in lockstep)."""
        self.create_subscription(
            JointState, JOINT_STATES, WithInfo(self.on_joint_states), READER_QOS
        )

    def listen_once_estimated(self) -> None:
        """Lockstep force mode: subscribe states once every estimator publisher is matched."""
        matched = self.forces_subscription.get_publisher_count()
        if matched == 0 or matched < self.count_publishers(self.forces_subscription.topic_name):
            return
        self.destroy_timer(self.estimator_timer)
        self.estimator_timer = None
        self.listen_to_states()
        self.get_logger().info(f'estimator matched: answering {JOINT_STATES}')

    def on_joint_states(self, message: JointState, info: dict) -> None:
        """Keep valid, recently stamped joint angles (rad) with their arrival time.

        In lockstep the state's stamp is the time itself (a node that has just started has not
        heard ``/clock`` yet), so it is not compared with the node clock. In lockstep with
        valves a state is answered once paired with its step's pressure (a refused state keeps
        its place in the pairing, and is not answered).
        """
        stamp = stamp_seconds(message.header.stamp)
        try:
            angles = joint_positions(message)
            if not self.lockstep:
                stamp_age(stamp, self.now_seconds(), self.values['feedback_timeout'], JOINT_STATES)
        except InvalidInputError as error:
            self.reject(JOINT_STATES, error)
            angles = None
        if self.pairer is not None:
            number = info['publication_sequence_number']
            self.take_pairs(self.pairer.add_angles(angles, sent_seconds(info), number, stamp))
        elif angles is not None:
            self.take_state(stamp, angles, None)

    def on_pressure(self, message: Float64MultiArray, info: dict) -> None:
        """Valves: keep a valid measured chamber pressure (Pa) with its arrival time."""
        pressure = self.pressure_reading(message.data)
        if pressure is not None:
            self.pressure = (self.now_seconds(), pressure)
        if self.pairer is not None:
            self.take_pairs(self.pairer.add_pressure(pressure, sent_seconds(info)))

    def take_pairs(self, pairs: list[Pair]) -> None:
        """Lockstep valves: take each state paired with its pressure (``Pair.state``: stamp)."""
        for pair in pairs:
            self.take_state(pair.state, pair.angles, pair.pressure)

    def take_state(self, stamp: float, angles: np.ndarray, pressure: np.ndarray | None) -> None:
        """Take a valid state stamped ``stamp`` (s); in lockstep, answer it.

        ``angles`` in rad; ``pressure`` (lockstep valves) the chamber pressures of its step, Pa.
        """
        if self.lockstep and self.last_tick is not None and stamp < self.last_tick:
            self.start_over(None)  # time went back: a new session, from this state
            self.get_logger().info(f'{JOINT_STATES} went back to t = {stamp:.9f} s: a new session')
        self.angles = (self.now_seconds(), angles)
        if self.lockstep:
            self.pending['angles'] = (stamp, angles)
            self.pending['pressure'] = pressure
            self.answer()

    def on_forces(self, message: JointState) -> None:
        """Keep valid estimated contact forces (N, ``effort``) with their arrival time.

        In lockstep also with the stamp of the state they estimate, which pairs them with it.
        """
        try:
            forces = joint_vector(message.effort, ESTIMATED_CONTACT_FORCES, MAX_FORCE_READING)
            stamp = stamp_seconds(message.header.stamp)
        except InvalidInputError as error:
            self.reject(ESTIMATED_CONTACT_FORCES, error)
            return
        self.forces = (self.now_seconds(), forces)
        if self.lockstep:
            self.pending['forces'] = (stamp, forces)
            self.answer()

    def on_targets(self, message: Float64MultiArray) -> None:
        """New position targets (rad), accepted only inside the range of motion."""
        limits = self.loop.limiter.limits
        try:
            targets = joint_vector(message.data, JOINT_TARGETS)
            outside = (targets < limits.joint_lower) | (targets > limits.joint_upper)
            if outside.any():
                raise InvalidInputError(
                    'out of range',
                    f'{JOINT_TARGETS} {targets.tolist()} rad outside the range of motion',
                )
        except InvalidInputError as error:
            self.reject(JOINT_TARGETS, error)
            return
        self.topic_targets = targets
        if isinstance(self.loop.controller, PositionController):
            self.loop.controller.set_targets(targets)

    def fresh(self, sample: tuple[float, np.ndarray] | None, now: float) -> np.ndarray | None:
        """The sample's value if it is younger than feedback_timeout, else None."""
        if sample is None or now - sample[0] > self.values['feedback_timeout']:
            return None
        return sample[1]

    # -- the loop --------------------------------------------------------------------------

    def tick(self) -> None:
        """Timer: compute, limit and publish one command from the freshest feedback."""
        now = self.now_seconds()
        # Never more than one period (the rate limit stays a limit when a tick runs late),
        # never negative (a clock set back).
        elapsed = self.period if self.last_tick is None else now - self.last_tick
        dt = min(max(elapsed, 0.0), self.period)
        self.last_tick = now
        feedback = Feedback(self.fresh(self.angles, now), self.fresh(self.forces, now))
        self.command(now, dt, feedback, self.fresh(self.pressure, now))

    def answer(self) -> None:
        """Lockstep: one command for the pending state (and, in force mode, its estimate).

        The state's stamp is the controller's time; dt is the step between two stamps. In force
        mode the estimate is the one stamped with the state's stamp: an estimate of an earlier
        state (late, or of a state this node did not answer) is dropped.
        """
        state, forces = self.pending['angles'], self.pending['forces']
        if isinstance(self.loop.controller, ForceController):
            if state is not None and forces is not None and forces[0] < state[0]:
                self.pending['forces'] = forces = None
            if state is None or forces is None or forces[0] != state[0]:
                return
        elif state is None:
            return
        pressure = self.pending['pressure']
        self.pending = {'angles': None, 'forces': None, 'pressure': None}
        stamp, angles = state
        if self.started is None:
            self.started = stamp
        dt = self.period if self.last_tick is None else max(stamp - self.last_tick, 0.0)
        self.last_tick = stamp
        self.command(stamp, dt, Feedback(angles, None if forces is None else forces[1]), pressure)

    def command(
        self, now: float, dt: float, feedback: Feedback, measured: np.ndarray | None
    ) -> None:
        """Compute, limit and publish the command at ``now`` (s) after ``dt`` (s).

        With valves the limited pressures are the loop's targets and ``measured`` the chamber
        pressures (Pa) it closes on: None (none fresh) vents.
        """
        result = self.loop.command(now - self.started, dt, feedback)
        if result.missing:
            self.get_logger().warning(
                f'{self.values["mode"]} mode: no fresh feedback for over '
                f'{self.values["feedback_timeout"]:g} s: ramping down to zero',
                throttle_duration_sec=LOG_THROTTLE,
            )
        for kind in result.reasons:
            self.limit_counts[kind] = self.limit_counts.get(kind, 0) + 1
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
        now = self.now_seconds()
        problems = []
        if self.fresh(self.angles, now) is None:
            problems.append(f'no fresh {JOINT_STATES} (is the plant running?)')
        backed_off = self.limit_counts.get('back-off', 0) - self.back_offs_reported
        if backed_off:
            problems.append(f'{backed_off} steps {self.last_back_off}')
            self.back_offs_reported += backed_off
        if self.valves and self.fresh(self.pressure, now) is None:
            problems.append(f'no fresh {CHAMBER_PRESSURE}: venting')
        sent = 'valve command sent (in, then out)' if self.valves else 'command sent (Pa)'
        values = {
            'mode': self.values['mode'],
            sent: str(self.sent.tolist()),
            'pressure target (Pa)': str(self.target.tolist()),
            'joint_states age (s)': 'none'
            if self.angles is None
            else f'{now - self.angles[0]:.3f}',
            **{f'limited steps: {kind}': str(n) for kind, n in self.limit_counts.items()},
        }
        level = DiagnosticStatus.WARN if problems else DiagnosticStatus.OK
        self.publish_status(level, '; '.join(problems) or 'running', values)


def main(args: list[str] | None = None) -> int:
    """Console script ``pressure_command`` (``ros2 run exodigit_nodes pressure_command``)."""
    return run(PressureCommand, args)


if __name__ == '__main__':
    raise SystemExit(main())
