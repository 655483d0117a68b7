"""Controllers of a batch of gloves: the protocol a virtual-patient trial steps, and the modes.

A trial steps N gloves, one per patient, as one batch (``GloveSimulation(count=N)`` or a
population) and asks its controller for the N commands at every step. Any object with the two
methods of :class:`BatchController` can be that controller: a user's own, a built-in mode of
``pressure_command`` behind its safety limiter (:class:`BuiltInMode`), or a Gymnasium policy
(:class:`exodigit_model.gym.env.PolicyController`).

>>> from exodigit_model import GloveSimulation
>>> from exodigit_model.control import BuiltInMode, SafetyLimits, Sine
>>> controller = BuiltInMode(Sine(0.0, 40e3, 4.0), SafetyLimits())
>>> simulation = GloveSimulation(count=1000)
>>> controller.reset(1000)
>>> state = simulation.state
>>> for _ in range(100):
...     state = simulation.step(controller.command(state.t, simulation.period, state))
>>> state.command.shape, int(controller.last.acted.any(axis=1).sum())
((1000, 3), 0)
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Protocol, runtime_checkable

import numpy as np
from numpy.typing import NDArray

from .controllers import Command, CommandLoop, Controller, Feedback, ForceController
from .safety import SafetyLimiter, SafetyLimits

if TYPE_CHECKING:
    from ..physics.model import GloveModel
    from ..stepping.simulation import GloveState


@runtime_checkable
class BatchController(Protocol):
    """A controller of N gloves at once: what a trial steps.

    A session is :meth:`reset` once, then :meth:`command` at every step, answering each state
    with the next commands, as ``pressure_command`` answers each ``joint_states`` in lockstep.
    Work on whole arrays (one row per glove) rather than loop over the gloves: a trial of 10,000
    patients leaves a controller a few milliseconds a step.
    """

    def reset(self, count: int, rng: np.random.Generator | None = None) -> None:
        """Start a session of ``count`` gloves: forget every glove's state.

        Parameters
        ----------
        count : int
            Gloves in the batch, N.
        rng : numpy.random.Generator, optional
            The trial's seeded generator, for a controller that draws random numbers (the same
            seed gives the same session); None: none is given.
        """

    def command(self, t: float, dt: float, state: GloveState) -> NDArray[np.float64]:
        """The chamber pressure commands for the next step, Pa, shape (N, 3).

        Parameters
        ----------
        t : float
            Time since the session started, s (``state.t`` in a trial).
        dt : float
            Time since the previous command, s (the step, 1/rate).
        state : GloveState
            The batch now, arrays (N, 3). What a real glove's sensors give is
            ``q_measured``, ``qdot`` and ``pressure_measured``; the true state (``q``,
            ``forces``, ...) is there too, for controllers that are allowed to know it.
        """


class BuiltInMode:
    """A built-in mode of ``pressure_command`` behind its safety limiter, as a BatchController.

    Every step computes for every glove what the node computes (:class:`.CommandLoop`), from
    the feedback the node gets (:meth:`.Feedback.of_state`): the measured joint angles and,
    with an ``estimator``, the robot-side estimate of the contact forces, the estimator
    node's. Closed loops and the estimate use the nominal model, as on the ROS graph: the
    controller does not know the patient.

    Parameters
    ----------
    controller : Controller
        The mode: :class:`.Staircase`, :class:`.Sine`, :class:`.Hold`,
        :class:`.PositionController` or :class:`.ForceController`. :meth:`reset` resets it for
        the batch.
    limits : SafetyLimits, optional
        The safety limits (default: the node's).
    estimator : GloveModel, optional
        The model of the force estimate (the nominal glove). None: no force feedback, so the
        limiter checks the range of motion only (as the node without an estimator); the force
        mode needs one.

    Raises
    ------
    ValueError
        For the force mode without an ``estimator``.
    """

    def __init__(
        self,
        controller: Controller,
        limits: SafetyLimits | None = None,
        *,
        estimator: GloveModel | None = None,
    ) -> None:
        if isinstance(controller, ForceController) and estimator is None:
            raise ValueError('the force mode needs an estimator (its feedback), got None')
        limiter = SafetyLimiter(SafetyLimits() if limits is None else limits)
        self.loop = CommandLoop(controller, limiter)
        self.estimator = estimator
        self.last: Command | None = None
        """The last command: its pressures, the limits that acted per glove (``acted``,
        (N, 5)) and why, and whether the feedback was missing; None before the first."""

    def reset(self, count: int, rng: np.random.Generator | None = None) -> None:
        """A new session of ``count`` gloves: integrators, limiter memory and caps emptied.

        ``rng`` is not used: the built-in modes draw no random numbers.
        """
        self.loop.controller.reset(count)
        self.loop.limiter.reset(count)
        self.last = None

    def command(self, t: float, dt: float, state: GloveState) -> NDArray[np.float64]:
        """The limited commands of every glove, Pa, (N, 3) (:meth:`BatchController.command`).

        Raises
        ------
        ValueError
            If ``state`` does not hold the ``count`` gloves of the last :meth:`reset`.
        """
        self.last = self.loop.command(t, dt, Feedback.of_state(state, self.estimator))
        return self.last.pressure
