"""Pressure controllers of the ``pressure_command`` node: open-loop sessions and closed loops.

Each controller gives the desired chamber pressures (Pa, MCP, PIP, DIP) at time ``t`` (s since
the session started) from the latest feedback; the safety limiter (:mod:`.safety`) then bounds
them, and closed loops are told what was actually sent (:meth:`PIController.commit`) so their
integrators do not wind up against the limits.

The same objects control one glove, arrays of shape (3,) as the node does, or a batch of N
gloves, (N, 3), with the same arithmetic (:mod:`.shapes`): a closed loop made with ``count=N``
keeps an integrator per glove, and an open-loop session, a function of time, gives every glove
the same pressures.
"""

from __future__ import annotations

import contextlib
import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .safety import SafetyLimiter
from .shapes import check_shape, glove_shape

if TYPE_CHECKING:
    from ..physics.model import GloveModel
    from ..stepping.simulation import GloveState

MODES = {
    'staircase': "steps of staircase_step up to staircase_peak and back, as in the paper's tests",
    'sine': 'continuous passive motion between sine_low and sine_high',
    'hold': 'constant hold_pressure',
    'position': 'joint_targets or joint_trajectory by model feed-forward plus PI on joint_states',
    'force': 'force_targets, contact forces, by feed-forward plus PI on estimated_contact_forces',
}
"""The sessions of ``pressure_command`` (its ``mode`` parameter), each with what it commands."""

MODE_DEFAULTS = {
    'staircase': {'staircase_step': 10e3, 'staircase_peak': 50e3, 'step_duration': 2.0},
    'sine': {'sine_low': 0.0, 'sine_high': 40e3, 'sine_period': 4.0},
    'hold': {'hold_pressure': (20e3, 20e3, 20e3)},
    'position': {'position_kp': 5e4, 'position_ki': 3e5},
    'force': {'force_targets': (0.1, 0.1, 0.1), 'force_kp': 5e4, 'force_ki': 5e5},
}
"""Each mode's parameters and their defaults, SI (Pa, s, N; gains Pa/rad, Pa/(rad·s), Pa/N,
Pa/(N·s)): the ``pressure_command`` node's defaults (its table reads them from here) and a
trial's (:mod:`exodigit_model.trials.controllers`)."""


@dataclass(frozen=True)
class Feedback:
    """Latest measurements; ``None`` when none (or none fresh) has arrived.

    Attributes
    ----------
    angles : ndarray, shape (3,) or (N, 3), optional
        Joint angles from ``joint_states``, rad.
    forces : ndarray, shape (3,) or (N, 3), optional
        Contact forces from ``estimated_contact_forces``, N.
    """

    angles: NDArray[np.float64] | None = None
    forces: NDArray[np.float64] | None = None

    @classmethod
    def of_state(cls, state: GloveState, estimator: GloveModel | None) -> Feedback:
        """What ``pressure_command`` hears of a simulated glove (or batch) ``state``.

        The measured joint angles, and with an ``estimator`` the ``estimator`` node's contact
        forces: the robot-side estimate from the measured angles and pressures
        (docs/spec/model.md §7), which needs no finger model. No forces where no bottom-face
        strain balances the segments (extensible segments; the node then publishes none): for
        a batch, when that happens in any row.
        """
        angles, forces = state.q_measured, None
        if estimator is not None:
            one = np.ndim(angles) == 1
            estimate = estimator.estimate_forces if one else estimator.estimate_forces_batch
            with contextlib.suppress(ValueError):  # no strain balances: no estimate
                forces = estimate(angles, state.pressure_measured)
        return cls(angles, forces)


class OpenLoop:
    """A pressure schedule in time; feedback is not used."""

    closed_loop = False

    def reset(self, count: int | None = None) -> None:
        """Nothing to reset: a session is a function of time, shared by every glove."""

    def commit(self, raw: NDArray[np.float64], applied: NDArray[np.float64]) -> None:
        """Open loop: nothing to update."""


class Staircase(OpenLoop):
    """The paper's staircase: 0 → ``peak`` in steps of ``step``, then back down, repeated.

    Parameters
    ----------
    step : float
        Pressure step, Pa (10 kPa in the paper).
    peak : float
        Highest level, Pa (50 kPa in the paper); rounded down to a whole number of steps.
    step_duration : float
        Time on each level, s.
    """

    def __init__(self, step: float, peak: float, step_duration: float) -> None:
        count = math.floor(peak / step + 1e-9)
        rising = [i * step for i in range(count + 1)]
        self.levels = rising + rising[-2:0:-1]
        self.step_duration = step_duration

    def desired(self, t: float, feedback: Feedback, dt: float) -> NDArray[np.float64]:
        """All three chambers at the level of the current stair, Pa."""
        index = int(t // self.step_duration) % len(self.levels)
        return np.full(3, self.levels[index])


class Sine(OpenLoop):
    """Continuous passive motion: p(t) = low + (high − low)·(1 − cos 2πt/period)/2 on all chambers.

    Parameters
    ----------
    low, high : float
        Pressures at the ends of the motion, Pa.
    period : float
        Duration of one flex-extend cycle, s.
    """

    def __init__(self, low: float, high: float, period: float) -> None:
        self.low, self.high, self.period = low, high, period

    def desired(self, t: float, feedback: Feedback, dt: float) -> NDArray[np.float64]:
        """The three pressures at ``t``, Pa; starts at ``low``."""
        phase = 0.5 * (1.0 - math.cos(2.0 * math.pi * t / self.period))
        return np.full(3, self.low + (self.high - self.low) * phase)


class Hold(OpenLoop):
    """Constant pressures, Pa (MCP, PIP, DIP): shape (3,), or (N, 3) for each glove its own."""

    def __init__(self, pressure: NDArray[np.float64]) -> None:
        self.pressure = np.array(pressure, dtype=float)

    def desired(self, t: float, feedback: Feedback, dt: float) -> NDArray[np.float64]:
        """The held pressures, Pa."""
        return self.pressure.copy()


class PIController:
    """Per-joint PI with conditional-integration anti-windup.

    u = feed-forward + kp·e + ki·∫e dt. An integration step is kept only where the limiter left
    the output alone, or where it moves the output back inside the limit.

    Parameters
    ----------
    kp, ki : float
        Proportional and integral gains (units of the output per unit error, and per unit
        error-second).
    count : int, optional
        Gloves controlled together, each with its own integrator; None: one glove.
    """

    def __init__(self, kp: float, ki: float, *, count: int | None = None) -> None:
        self.kp, self.ki = kp, ki
        self.reset(count)

    def reset(self, count: int | None = None) -> None:
        """Empty integrators for one glove (``count`` None) or ``count`` gloves."""
        shape = glove_shape(count)
        self.integral = np.zeros(shape)
        self._step = np.zeros(shape)

    def output(
        self, feedforward: NDArray[np.float64], error: NDArray[np.float64] | None, dt: float
    ) -> NDArray[np.float64]:
        """The raw output; no error (no feedback yet) gives the feed-forward plus the integral."""
        self._step = np.zeros(self.integral.shape) if error is None else error * dt
        proportional = 0.0 if error is None else self.kp * error
        return feedforward + proportional + self.ki * (self.integral + self._step)

    def commit(self, raw: NDArray[np.float64], applied: NDArray[np.float64]) -> None:
        """Keep the integration step except where it pushed further into a limit."""
        clipped = raw - applied
        winding = ((clipped > 0.0) & (self._step > 0.0)) | ((clipped < 0.0) & (self._step < 0.0))
        self.integral = np.where(winding, self.integral, self.integral + self._step)


class PositionController(PIController):
    """Joint-angle control: feed-forward ``GloveModel.pressure_for`` (eq 36 inverse) plus PI.

    Parameters
    ----------
    model : GloveModel
        Model of the glove and finger used for the feed-forward (the nominal one: the
        controller does not know the patient).
    targets : array_like, shape (3,)
        Desired joint angles, rad, the same for every glove.
    kp : float
        Pa per rad of angle error.
    ki : float
        Pa per rad·s of integrated angle error.
    count : int, optional
        Gloves controlled together; None: one glove.
    """

    closed_loop = True

    def __init__(
        self, model: GloveModel, targets, kp: float, ki: float, *, count: int | None = None
    ) -> None:
        super().__init__(kp, ki, count=count)
        self.model = model
        self.set_targets(targets)

    def set_targets(self, targets) -> None:
        """New desired angles, rad; the feed-forward is recomputed once here."""
        self.targets = np.array(targets, dtype=float)
        self.feedforward = self.model.pressure_for(self.targets)

    def desired(self, t: float, feedback: Feedback, dt: float) -> NDArray[np.float64]:
        """Feed-forward plus PI on the angle error, Pa."""
        error = None if feedback.angles is None else self.targets - feedback.angles
        return self.output(self.feedforward, error, dt)


class ForceController(PIController):
    """Contact-force control: robot-side feed-forward plus PI on ``estimated_contact_forces``.

    The feed-forward is the pressure that makes the robot-side estimate (docs/spec/model.md §7)
    equal the target at the measured angles: p = B_R⁻¹((J_R*)ᵀ·f* − τ_s(q)), so it needs no
    finger model.

    Parameters
    ----------
    model : GloveModel
        Model of the exo-digit (its finger part is not used).
    targets : array_like, shape (3,)
        Desired contact forces, N, the same for every glove.
    kp : float
        Pa per N of force error.
    ki : float
        Pa per N·s of integrated force error.
    count : int, optional
        Gloves controlled together; None: one glove.
    """

    closed_loop = True

    def __init__(
        self, model: GloveModel, targets, kp: float, ki: float, *, count: int | None = None
    ) -> None:
        super().__init__(kp, ki, count=count)
        self.model = model
        self.targets = np.array(targets, dtype=float)
        self._moments = np.asarray(model.constants.pressure_moments)

    def feedforward(self, angles: NDArray[np.float64]) -> NDArray[np.float64]:
        """Pressures giving the target forces at ``angles``, Pa (docs/spec/model.md §7, for p).

        ``angles`` (rad) of one glove, (3,), or of a batch, (N, 3).
        """
        robot = self.model.robot_contact_torque(
            angles, np.broadcast_to(self.targets, angles.shape)
        )
        torque = robot - self.model.structural_torque(angles)
        return torque / self._moments

    def desired(self, t: float, feedback: Feedback, dt: float) -> NDArray[np.float64]:
        """Feed-forward at the measured angles (zero angles before any) plus PI on force, Pa."""
        angles = np.zeros(self.integral.shape) if feedback.angles is None else feedback.angles
        error = None if feedback.forces is None else self.targets - feedback.forces
        return self.output(self.feedforward(angles), error, dt)


Controller = OpenLoop | PositionController | ForceController


def mode_controller(
    mode: str, values: Mapping[str, Any], model: Callable[[], GloveModel], targets: ArrayLike
) -> Controller:
    """The controller of a ``pressure_command`` mode (:data:`MODES`) from its parameters.

    ``values`` holds the mode's parameters by the node's names (:data:`MODE_DEFAULTS`);
    ``model()`` gives the feed-forward's model, asked for only by ``position`` and ``force``;
    ``targets`` are the angles (rad) ``position`` starts at. The node's modes and a trial's.
    """
    v = values
    if mode == 'staircase':
        return Staircase(v['staircase_step'], v['staircase_peak'], v['step_duration'])
    if mode == 'sine':
        return Sine(v['sine_low'], v['sine_high'], v['sine_period'])
    if mode == 'hold':
        return Hold(np.array(v['hold_pressure']))
    if mode == 'position':
        return PositionController(model(), targets, v['position_kp'], v['position_ki'])
    return ForceController(model(), v['force_targets'], v['force_kp'], v['force_ki'])


@dataclass(frozen=True)
class Command:
    """One command of :class:`CommandLoop`: what to send, and what shaped it.

    Attributes
    ----------
    pressure : ndarray, shape (3,) or (N, 3)
        The pressures to send, Pa.
    reasons : dict of str to str
        The safety limits that acted, and why (see :class:`.safety.Limited`).
    missing : bool
        A closed loop had no fresh feedback and ramps down to zero (feedback comes for the
        whole batch or not at all, so this is one answer for every glove).
    acted : ndarray of bool, shape (5,) or (N, 5)
        Whether each limit of :data:`.safety.LIMIT_KINDS` acted, per glove.
    """

    pressure: NDArray[np.float64]
    reasons: dict[str, str]
    missing: bool
    acted: NDArray[np.bool_]


class CommandLoop:
    """A controller behind the safety limiter: what ``pressure_command`` computes each step.

    Plain Python, so a controller can be run against an in-process simulation exactly as the
    node runs it: for one glove, or for a batch when the controller and the limiter are made
    for it (``count=N``; :class:`.batch.BuiltInMode` does so).

    Parameters
    ----------
    controller : Controller
        Open-loop session or closed loop (replaceable: ``loop.controller = ...``).
    limiter : SafetyLimiter
        The safety limits every command passes.
    """

    def __init__(self, controller: Controller, limiter: SafetyLimiter) -> None:
        self.controller, self.limiter = controller, limiter

    def command(self, t: float, dt: float, feedback: Feedback) -> Command:
        """The command at session time ``t`` (s), ``dt`` (s) after the previous one.

        Raises
        ------
        ValueError
            If the feedback, or a closed loop's integrator, does not have the limiter's shape.
        """
        controller, shape = self.controller, self.limiter.shape
        check_shape('feedback.angles', feedback.angles, shape)
        check_shape('feedback.forces', feedback.forces, shape)
        if controller.closed_loop:
            check_shape('the integrator', controller.integral, shape)
        missing = controller.closed_loop and (
            feedback.angles is None
            or (isinstance(controller, ForceController) and feedback.forces is None)
        )
        if missing:
            desired = np.zeros(3)
            controller.integral[:] = 0.0  # start afresh when the feedback returns
        else:
            desired = controller.desired(t, feedback, dt)
        limited = self.limiter.apply(desired, dt, feedback.angles, feedback.forces)
        if not missing:
            controller.commit(desired, limited.pressure)
        return Command(limited.pressure, limited.reasons, missing, limited.acted)
