"""A Gymnasium environment of the simulated glove: :class:`GloveEnv` (docs/spec/model.md §13).

The optional ``gym`` extra (``pip install "./exodigit_model[gym]"``) provides Gymnasium; only this
module imports it, never the core package. :class:`GloveEnv` steps one glove in-process (no
ROS, no DDS) with the same :class:`~exodigit_model.stepping.simulation.GloveSimulation` as the ROS
plant, behind the same safety limiter as the ROS graph's ``pressure_command``
(:mod:`exodigit_model.control`), so an agent trained here meets the same physics and the same
limits on the ROS graph.

Importing the module registers the environment as ``exodigit/Glove-v0``:

>>> import gymnasium
>>> import exodigit_model.gym.env
>>> env = gymnasium.make('exodigit/Glove-v0', episode_steps=100)
>>> observation, info = env.reset(seed=1)
>>> observation.shape, env.action_space.low.tolist(), env.action_space.high.tolist()
((12,), [-1.0, -1.0, -1.0], [1.0, 1.0, 1.0])
>>> observation, reward, terminated, truncated, info = env.step([0.0, 0.0, 0.0])
>>> info['command'].tolist()  # the middle of [0, 60 kPa], the limiter's highest pressure
[30000.0, 30000.0, 30000.0]
>>> bool(reward < 0.0), terminated, truncated
(True, False, False)
"""

from __future__ import annotations

import math
import os
from collections.abc import Callable
from dataclasses import dataclass, replace
from typing import Any, ClassVar

import gymnasium
import numpy as np
from gymnasium import spaces
from numpy.typing import ArrayLike, NDArray

from ..control import Feedback, Limited, SafetyLimiter, SafetyLimits, Trajectory
from ..control.cycles import flex_extend
from ..control.shapes import check_shape
from ..physics.model import GloveModel, as_joint_rows, as_joint_vector
from ..physics.params import GloveParams, load_params
from ..stepping.settings import ACTUATIONS, NANOSECONDS, OPENINGS, SimulationSettings, step_time_ns
from ..stepping.simulation import GloveSimulation, GloveState

ENV_ID = 'exodigit/Glove-v0'
"""The id under which importing this module registers :class:`GloveEnv` with Gymnasium."""

DEFAULT_EPISODE_STEPS = 400
"""Steps per episode: 4 s at the default 100 Hz, one period of the default target."""

DEFAULT_TARGET_PERIOD = 4.0
"""Period of the default flex-extend target, s."""

DEFAULT_PEAK_FRACTION = 0.5
"""The default target peaks at the angles of this fraction of the supply in every chamber."""

ANGLE_BOUND = math.pi
"""|q| bound of the observed angles, rad (beyond any bend the model is validated for)."""

NOISE_MARGIN = 10.0
"""Standard deviations of sensor noise added to the bounds of the measured observations."""

SEED_BOUND = 2**63
"""Noise seeds drawn for an unseeded reset lie in [0, this)."""

NODE_SAFETY = SafetyLimits()
"""The ``pressure_command`` node's default limits (60 kPa, 100 kPa/s, range of motion, 10 N)."""

OPEN_PRESSURE_RATE = 1e8
"""The rate limit of :data:`DEFAULT_SAFETY`, Pa/s: a swing across a 100 kPa supply in 1 ms, so
at any rate up to 1 kHz no action is slowed; the highest ``max_pressure_rate`` the
``pressure_command`` node accepts, which gives the ROS graph the same limits."""

DEFAULT_SAFETY = replace(NODE_SAFETY, max_pressure_rate=OPEN_PRESSURE_RATE)
"""The limits between the agent and the chambers by default: the node's, without its rate limit.

The node's 100 kPa/s (1 kPa a step at 100 Hz) slows nearly every action of an exploring policy
(99.996 % of random normalized actions, where these limits acted on none:
benchmarks/bench_rl_limiter.py, docs/gym.md "The safety limiter"), so what the policy chose
would rarely be what the glove got; the range of motion and the contact force stay guarded, and
the pressure limit is the top of the normalized action range."""

ACTION_SCALES = ('normalized', 'physical')
"""How actions are given: ``'normalized'``, [−1, 1] per chamber (or valve), mapped linearly onto
the physical range inside the environment; ``'physical'``, Pa (or openings in [0, 1])."""

VALVE_PRESSURE_MARGIN = 5e3
"""Behind valves, Pa beyond [0, supply] still inside the observed pressures' bounds: a closed
chamber whose volume (14.1) shrinks or grows as the coupled finger moves leaves that range
(measured: 0.8 kPa above the 100 kPa supply and 0.5 kPa below zero in 2,000 steps of 200
gloves under random openings)."""

VALVE_INFO_KEYS = ('mass', 'volume')
"""The info keys only behind valves: the chambers' air masses (kg) and volumes (m³), (3,)."""

Target = Callable[[float], ArrayLike] | Trajectory
"""target(t) -> desired joint angles (MCP, PIP, DIP) at time t (s), rad; or a trajectory."""

Reward = Callable[[GloveState, NDArray[np.float64], NDArray[np.float64]], float]
"""reward(state, target, action) -> float; ``state`` after the step, ``target`` at ``state.t``."""


@dataclass(frozen=True)
class FlexExtendTarget:
    r"""A slow flex-extend: q*(t) = peak · (1 − cos(2πt / period)) / 2, rad.

    The continuous passive motion of the trials from the straight finger
    (:func:`exodigit_model.control.cycles.flex_extend` with low = 0, high = ``peak``).

    Starts at rest (q* = 0 at t = 0), reaches ``peak`` at t = period/2 and returns to rest at
    t = period. Every point lies on the straight line from 0 to ``peak``; for the default
    target (:meth:`for_model`), whose peak the model reaches with equal pressures, every point
    of that line is held by pressures inside the supply range (a test checks it with the exact
    inverse, :meth:`GloveModel.pressure_for`).

    Attributes
    ----------
    peak : tuple of float
        Joint angles at the top of the flexion, MCP, PIP, DIP, rad.
    period : float
        Duration of one flex-extend cycle, s (> 0).
    """

    peak: tuple[float, float, float]
    period: float = DEFAULT_TARGET_PERIOD

    def __post_init__(self) -> None:
        """Refuse a peak that is not three finite angles or a period that is not > 0."""
        object.__setattr__(self, 'peak', tuple(as_joint_vector('peak', self.peak).tolist()))
        if isinstance(self.period, bool) or not isinstance(self.period, int | float):
            raise ValueError(f'period = {self.period!r}: must be a number of seconds')
        if not (math.isfinite(self.period) and self.period > 0.0):
            raise ValueError(f'period = {self.period!r}: must be finite and > 0 s')

    @classmethod
    def for_model(
        cls, model: GloveModel, pressure: float, period: float = DEFAULT_TARGET_PERIOD
    ) -> FlexExtendTarget:
        """The flex-extend whose peak is the model's solve at ``pressure`` Pa in every chamber.

        Raises
        ------
        ValueError
            If the coupled solve (docs/spec/model.md §7) at that pressure does not converge, or
            its state leaves the model (the validated stretch or the finger's range of motion).
        """
        solution = model.solve([pressure, pressure, pressure])
        problems = solution.warnings()
        if problems:
            raise ValueError(
                f'model: at {pressure:g} Pa in every chamber {"; ".join(problems)} (residual '
                f'{solution.residual:.3g} N·m), so there is no default target; pass target='
            )
        return cls(tuple(solution.q.tolist()), period)

    def __call__(self, t: float) -> NDArray[np.float64]:
        """q*(t), rad, shape (3,): the trials' flex-extend cycle from rest to ``peak``."""
        return flex_extend(t, np.zeros(3), np.array(self.peak), self.period)


def tracking_reward(
    state: GloveState, target: NDArray[np.float64], action: NDArray[np.float64]
) -> float:
    r"""The default reward: r = −Σ_j (q_j − q*_j)², rad².

    ``q`` is the true joint angle after the step (``state.q``, not the noisy measurement: the
    reward scores the finger, not the sensor), q* the target at the same time ``state.t``. The
    action is not used; a reward with an effort or a rate term can use it. Over a batch
    (``state.q`` of shape (N, 3), as :class:`~exodigit_model.gym.vector.GloveVectorEnv` calls
    it) it returns the N rewards, each summed in the order MCP, PIP, DIP as for one glove, so
    a glove's reward is the same bit for bit either way.
    """
    squared = np.square(state.q - target)
    total = squared[..., 0] + squared[..., 1] + squared[..., 2]
    return -total if np.ndim(total) else -float(total)


class GloveEnv(gymnasium.Env):
    r"""One simulated glove as a Gymnasium environment (docs/spec/model.md §13), tracking a target.

    Each step maps the action onto the physical range (:attr:`physical_action_space`), passes
    it through the safety limiter of the ROS graph's ``pressure_command`` and applies what it
    lets through as the chamber pressure command for Δt = 1/``rate_hz``: the chambers lag
    toward it (clipped to the supply range), the coupled quasi-static equations are solved at
    the new pressures, and the sensors are read with seeded noise.

    Parameters
    ----------
    model : GloveModel, optional
        The glove and finger. Give this or ``params``, not both; neither = the defaults of
        docs/spec/model.md §10.
    params : str, PathLike or GloveParams, optional
        A parameter file (YAML, SI, merged over the defaults, docs/spec/model.md §10) or loaded
        parameters, instead of ``model``.
    settings : SimulationSettings, optional
        Rate, chamber lag, supply, sensor noise; the ROS plant's defaults when omitted
        (100 Hz, T = 0.05 s, 100 kPa supply, no noise). Its ``seed`` is not used: the noise
        seed follows :meth:`reset`'s ``seed``.
    episode_steps : int, optional
        Steps per episode (≥ 1); the step that completes them returns ``truncated=True``.
    target : callable or Trajectory, optional
        ``target(t) -> (3,)``: desired joint angles at time t (s, from the reset), rad; or a
        :class:`~exodigit_model.control.Trajectory` from the reset, sampled at each step's time
        as ``pressure_command`` samples a ``joint_trajectory`` (the same targets). Default:
        :meth:`FlexExtendTarget.for_model` at ``DEFAULT_PEAK_FRACTION`` of the supply, period
        4 s (peak ≈ 28.9, 26.0, 17.1° with the default model and supply).
    reward : callable, optional
        ``reward(state, target, action) -> float`` with the :class:`GloveState` after the
        step, the target at ``state.t`` (rad, (3,)) and the physical action, before the
        limiter (Pa, (3,); openings (6,) behind valves). Default: :func:`tracking_reward`,
        −Σ(q − q*)² in rad².
    observe_target : bool, optional
        Whether the observation ends with the target of the next step (default True: without
        it the agent cannot know where the target is going).
    safety : SafetyLimits or None, optional
        The limiter's limits. Default :data:`DEFAULT_SAFETY`: the node's defaults (at most
        60 kPa, backing off outside the range of motion or above 10 N of contact force)
        without their rate limit; :data:`NODE_SAFETY` are the node's own, 100 kPa/s included.
        As on the ROS graph it sees the last measured angles and the robot-side estimate of the
        contact forces from the measured angles and pressures (the ``estimator`` node's). None
        sends the action to the chambers unlimited. Behind valves the default means None and
        other limits are refused (see Notes).
    actuation : str, optional
        One of :data:`~exodigit_model.stepping.simulation.ACTUATIONS`: ``'regulator'`` (default;
        the action is three chamber pressures) or ``'valves'`` (six valve openings,
        docs/spec/model.md §14).
    action_scale : str, optional
        One of :data:`ACTION_SCALES`: ``'normalized'`` (default; Box(−1, 1) per chamber, what
        RL libraries expect) or ``'physical'`` (the action space is
        :attr:`physical_action_space`).

    Notes
    -----
    **Action**, Box(−1, 1, (3,), float32): chamber pressure commands, MCP, PIP, DIP segment,
    mapped linearly onto :attr:`physical_action_space`, Box(0, p_top, (3,), float32) in Pa
    (−1 → 0 Pa, 1 → p_top), with p_top the limiter's ``max_pressure`` capped at the supply
    (the supply without a limiter); with ``action_scale='physical'`` the action is that Pa
    box itself. :meth:`physical_action` does the mapping. The limiter bounds the command
    first (``info['safety']`` says why it changed an action); commands outside the supply
    range are then clipped by the chambers (``info['saturated']``), as the plant clips them.
    Actions outside the box are mapped by the same line and then limited or clipped.

    **Observation**, float32, shape (12,) (or (9,) without the target), at t_k:

    - 0:3, measured joint angles q̃ (MCP, PIP, DIP), rad, bounds ±(π + 10 σ_q);
    - 3:6, joint velocities q̇ = (q_k − q_{k−1})/Δt, rad/s, bounds ±2π·rate_hz;
    - 6:9, measured chamber pressures p̃, Pa, bounds [−10 σ_p, p_max + 10 σ_p];
    - 9:12, the target q*(t_{k+1}) of the next step, rad, bounds ±π;

    with σ_q, σ_p the settings' noise standard deviations and p_max the supply.
    These are ``GloveState.q_measured``, ``.qdot`` and ``.pressure_measured`` cast to float32
    and clipped to the bounds, which only a state far outside the validated range or a noise
    draw of 10 σ reaches (``info['observation_clipped']`` says when).

    **Behind valves** (``actuation='valves'``) the action is Box(−1, 1, (6,), float32),
    mapped onto Box(0, 1, (6,), float32) (physical): the openings of the inlet valves (from
    the supply) of MCP, PIP, DIP, then of their outlet valves (to the atmosphere), held over
    the step; the chambers' air masses follow the valves' flows (14.3)-(14.4) and their
    pressures the gas law (14.2). The observation is the same:
    a chamber's air mass is m = (p + P_atm)·V(q)/(R·T) (14.1)-(14.2), a function of the
    observed pressure and angles, and the valves have no state of their own (an opening acts
    for its step only), so nothing a valve controller needs is hidden; a real glove has no
    sensor of the air mass either. Only the pressures' bounds widen by
    :data:`VALVE_PRESSURE_MARGIN` on both sides of [0, p_s] (p_s the pneumatics' supply,
    docs/spec/model.md §14), since a closed chamber's pressure moves with its volume. There is
    no safety limiter: it limits a pressure command, and openings are none; on the ROS graph
    an agent's ``valve_command`` reaches the plant past ``pressure_command``'s limiter too.
    ``info`` then also has ``mass`` and ``volume`` (:data:`VALVE_INFO_KEYS`), and ``command``
    is the six openings after clipping to [0, 1].

    **Reward** at t_k = round(k·10⁹/rate_hz)·10⁻⁹ s: ``reward(state_k, target(t_k), action)``.

    **Episode**: starts at rest (vented chambers, q at rest, t = 0). ``terminated`` when the
    step's coupled solve did not converge (the stepper kept the last good state, so the
    physics of the episode ends there); ``truncated`` after ``episode_steps`` steps. Leaving
    the model's validated stretch range (0.95 ≤ λ ≤ 1.5, :data:`.model.VALID_STRETCH`: the
    paper's range from λ = 1, extended down to 0.95 by docs/spec/model.md §12 because a bottom face
    slightly compressed by the finger is harmless) does not end the episode;
    ``info['in_valid_range']`` reports it.

    **Seeding**: ``reset(seed=s)`` runs the stepper with noise seed ``s``, so an episode equals
    ``GloveSimulation(model, replace(settings, seed=s))`` fed the same actions, bit for bit.
    ``reset()`` without a seed draws the noise seed from :attr:`np_random` (seeded by the last
    seed given): equal seeds give equal sequences of episodes.

    **Info** (new arrays every call): ``t`` (s), ``target`` (the target the reward used, rad),
    ``q`` (true angles, rad), ``pressure`` (true chamber pressures, Pa), ``command`` (the
    command applied, after the limiter and saturation, Pa), ``safety`` (per limit that acted
    on the action, why; empty when it went through), ``converged``, ``in_valid_range``,
    ``saturated``, ``observation_clipped`` and ``noise_seed``.
    """

    metadata: ClassVar[dict[str, Any]] = {'render_modes': []}

    def __init__(
        self,
        model: GloveModel | None = None,
        *,
        params: str | os.PathLike | GloveParams | None = None,
        settings: SimulationSettings | None = None,
        episode_steps: int = DEFAULT_EPISODE_STEPS,
        target: Target | None = None,
        reward: Reward | None = None,
        observe_target: bool = True,
        safety: SafetyLimits | None = DEFAULT_SAFETY,
        actuation: str = 'regulator',
        action_scale: str = 'normalized',
    ) -> None:
        self.model = _model(model, params)
        if settings is None:
            settings = SimulationSettings()
        elif not isinstance(settings, SimulationSettings):
            raise ValueError(f'settings = {settings!r}: must be a SimulationSettings (or None)')
        self.settings = settings
        if isinstance(episode_steps, bool) or not isinstance(episode_steps, int):
            raise ValueError(f'episode_steps = {episode_steps!r}: must be an integer')
        if episode_steps < 1:
            raise ValueError(f'episode_steps = {episode_steps!r}: must be >= 1')
        self.episode_steps = episode_steps
        for name, function in (('target', target), ('reward', reward)):
            if function is not None and not callable(function):
                raise ValueError(f'{name} = {function!r}: must be callable (or None)')
        if not isinstance(observe_target, bool):
            raise ValueError(f'observe_target = {observe_target!r}: must be True or False')
        if safety is not None and not isinstance(safety, SafetyLimits):
            raise ValueError(f'safety = {safety!r}: must be a SafetyLimits (or None)')
        if actuation not in ACTUATIONS:
            raise ValueError(f'actuation = {actuation!r}: must be one of {", ".join(ACTUATIONS)}')
        if action_scale not in ACTION_SCALES:
            raise ValueError(
                f'action_scale = {action_scale!r}: must be one of {", ".join(ACTION_SCALES)}'
            )
        self.actuation = actuation
        self.valves = actuation == 'valves'
        self.action_scale = action_scale
        if self.valves and safety is not DEFAULT_SAFETY and safety is not None:
            raise ValueError(
                f'safety = {safety!r}: behind valves the action is openings, which the '
                'limiter of pressure commands cannot limit; leave it out or pass None'
            )
        self.safety = None if self.valves else safety
        if target is None:
            target = FlexExtendTarget.for_model(
                self.model, DEFAULT_PEAK_FRACTION * settings.max_supply_pressure
            )
        self.target = target
        self.reward = tracking_reward if reward is None else reward
        self.observe_target = observe_target

        supply = settings.max_supply_pressure
        if self.valves:
            physical = spaces.Box(0.0, 1.0, (OPENINGS,), dtype=np.float32)
            supply = self.model.params.pneumatics.supply_pressure
            margin = VALVE_PRESSURE_MARGIN
            if supply is None:
                supply = settings.max_supply_pressure
        else:
            top = supply if self.safety is None else min(supply, self.safety.max_pressure)
            physical = spaces.Box(
                np.zeros(3, np.float32), np.full(3, top, np.float32), dtype=np.float32
            )
            margin = 0.0
        self.physical_action_space = physical
        """The actions in physical units: Pa (openings behind valves), float32."""
        if action_scale == 'physical':
            self.action_space = physical
        else:
            self.action_space = spaces.Box(-1.0, 1.0, physical.shape, dtype=np.float32)
        self._action_low = physical.low.astype(float)
        self._action_span = physical.high.astype(float) - self._action_low
        angle = ANGLE_BOUND + NOISE_MARGIN * settings.angle_noise_std
        velocity = 2.0 * ANGLE_BOUND * settings.rate_hz
        noise = NOISE_MARGIN * settings.pressure_noise_std
        high = [angle] * 3 + [velocity] * 3 + [supply + margin + noise] * 3
        low = [-angle] * 3 + [-velocity] * 3 + [-margin - noise] * 3
        if observe_target:
            high += [ANGLE_BOUND] * 3
            low += [-ANGLE_BOUND] * 3
        self.observation_space = spaces.Box(
            np.array(low, np.float32), np.array(high, np.float32), dtype=np.float32
        )

        self.simulation: GloveSimulation | None = None
        """The stepper of the current episode (a new one each reset); None before the first."""
        self.noise_seed: int | None = None
        """The sensor-noise seed of the current episode."""
        self._next_target = np.zeros(3)
        self._limiter: SafetyLimiter | None = None
        self._limited: dict[str, str] = {}

    def physical_action(self, action: NDArray[np.float64]) -> NDArray[np.float64]:
        """``action`` (one (3,) or (6,), or rows of them) in physical units: Pa or openings.

        Normalized: low + (a + 1)/2 · (high − low) of :attr:`physical_action_space`, elementwise
        (−1 → low, 1 → high); physical: ``action`` itself.
        """
        if self.action_scale == 'physical':
            return action
        return self._action_low + (action + 1.0) * 0.5 * self._action_span

    @property
    def state(self) -> GloveState | None:
        """The glove after the last step or reset (true and measured, float64), or None."""
        return None if self.simulation is None else self.simulation.state

    def reset(
        self, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[NDArray[np.float32], dict[str, Any]]:
        """Start an episode at rest at t = 0, with noise seed ``seed`` (or one drawn).

        Parameters
        ----------
        seed : int, optional
            Seeds :attr:`np_random` and is the stepper's noise seed; omitted, the noise seed
            is drawn from :attr:`np_random`.
        options : dict, optional
            No options exist; an empty dict or None.

        Returns
        -------
        observation : ndarray of float32
        info : dict
        """
        super().reset(seed=seed)
        if options:
            raise ValueError(f'options = {options!r}: GloveEnv takes no reset options')
        if seed is None:
            seed = int(self.np_random.integers(SEED_BOUND))
        self.noise_seed = seed
        self.simulation = GloveSimulation(
            self.model, replace(self.settings, seed=seed), actuation=self.actuation
        )
        self._limiter = None if self.safety is None else SafetyLimiter(self.safety)
        self._limited = {}
        state = self.simulation.state
        target = self.target_of_step(0)
        self._next_target = self.target_of_step(1)
        observation, clipped = self._observe(state)
        return observation, self._info(state, target, clipped)

    def step(
        self, action: ArrayLike
    ) -> tuple[NDArray[np.float32], float, bool, bool, dict[str, Any]]:
        """Apply ``action``: three chamber pressure commands (six openings behind valves).

        In [−1, 1] by default, in Pa (openings in [0, 1]) with ``action_scale='physical'``.

        Returns
        -------
        observation : ndarray of float32
        reward : float
        terminated : bool
            The coupled solve of this step did not converge.
        truncated : bool
            This step completed ``episode_steps``.
        info : dict

        Raises
        ------
        ValueError
            If ``action`` is not three (six) finite numbers, or ``target``/``reward`` return
            something that is not three finite angles / a finite number.
        gymnasium.error.ResetNeeded
            Before the first :meth:`reset`.
        """
        if self.simulation is None:
            raise gymnasium.error.ResetNeeded('GloveEnv: call reset() before step()')
        if self.valves:
            action = as_actions('action', action, self.action_space.shape)
        else:
            action = as_joint_vector('action', action)
        action = self.physical_action(action)
        state = self.simulation.step(self._limit(action))
        target = self._next_target
        reward = self.reward(state, target.copy(), action.copy())
        try:
            reward = float(reward)
        except (TypeError, ValueError):
            reward = math.nan
        if not math.isfinite(reward):
            raise ValueError(f'reward returned {reward!r} at t = {state.t} s: must be finite')
        self._next_target = self.target_of_step(state.step + 1)
        observation, clipped = self._observe(state)
        terminated = not bool(state.converged)
        truncated = state.step >= self.episode_steps
        return observation, reward, terminated, truncated, self._info(state, target, clipped)

    # -- helpers ---------------------------------------------------------------------------

    def _limit(self, action: NDArray[np.float64]) -> NDArray[np.float64]:
        """What the limiter lets through of ``action``, from the last measured state."""
        if self._limiter is None:
            return action
        feedback = Feedback.of_state(self.simulation.state, self.model)
        limited = self._limiter.apply(
            action, 1.0 / self.settings.rate_hz, feedback.angles, feedback.forces
        )
        self._limited = limited.reasons
        return limited.pressure

    def target_of_step(self, step: int) -> NDArray[np.float64]:
        """q*(t_k), rad, (3,): the target at the time of step k of an episode.

        t_k as the stepper reports it (:func:`~exodigit_model.stepping.settings.step_time_ns`); a
        :class:`~exodigit_model.control.Trajectory` is sampled at its whole nanoseconds.

        Raises
        ------
        ValueError
            If ``target`` does not return three finite angles.
        """
        time_ns = step_time_ns(step, self.settings.rate_hz)
        if isinstance(self.target, Trajectory):
            return self.target.at_ns(time_ns)
        t = time_ns / NANOSECONDS
        return as_joint_vector(f'target({t})', self.target(t))

    def _observe(self, state: GloveState) -> tuple[NDArray[np.float32], bool]:
        """The observation (a new float32 array) and whether clipping to the bounds changed it."""
        target = self._next_target if self.observe_target else None
        observation, clipped = observe(state, self.observation_space, target)
        return observation, bool(clipped)

    def _info(self, state: GloveState, target: NDArray[np.float64], clipped: bool) -> dict:
        valves = {key: getattr(state, key).copy() for key in VALVE_INFO_KEYS if self.valves}
        return {
            't': state.t,
            'target': target.copy(),
            'q': state.q.copy(),
            'pressure': state.pressure.copy(),
            'command': state.command.copy(),
            'safety': dict(self._limited),
            'converged': bool(state.converged),
            'in_valid_range': bool(state.in_valid_range),
            'saturated': bool(state.saturated),
            'observation_clipped': clipped,
            'noise_seed': self.noise_seed,
            **valves,
        }


def as_actions(name: str, value: ArrayLike, shape: tuple[int, ...]) -> NDArray[np.float64]:
    """``value`` as a new finite float64 array of ``shape`` (e.g. openings, (6,)), or a ValueError.

    Values outside the action space are let through: the simulation clips openings to [0, 1]
    and says so (``saturated``), as it clips pressures to the supply.
    """
    try:
        array = np.array(value, dtype=float)
    except (TypeError, ValueError):
        array = None
    if array is None or array.shape != shape:
        got = 'no array of numbers' if array is None else f'shape {array.shape}'
        raise ValueError(f'{name} must have shape {shape}, got {got}')
    if not np.all(np.isfinite(array)):
        raise ValueError(f'{name} must be finite, got {array.tolist()}')
    return array


def observe(
    state: GloveState, space: spaces.Box, target: NDArray[np.float64] | None
) -> tuple[NDArray[np.float32], NDArray[np.bool_]]:
    """:class:`GloveEnv`'s observation of one glove (3,) or of each glove of a batch (N, 3).

    Returns the observations, float32, (d,) or (N, d), clipped to ``space``, and whether the
    clipping changed them (per glove). ``target``: the next step's target angles (rad, (3,),
    every glove's), or None when not observed.
    """
    parts = [state.q_measured, state.qdot, state.pressure_measured]
    if target is not None:
        parts.append(np.broadcast_to(target, np.shape(state.q_measured)))
    # beyond float32's range: ±inf, clipped
    raw = np.concatenate(parts, axis=-1).astype(np.float32)
    observation = np.clip(raw, space.low, space.high)
    return observation, (raw != observation).any(axis=-1)


class PolicyController:
    """A policy for :class:`GloveEnv` run over a batch of gloves, as a ``BatchController``.

    At each step every glove of the batch is observed as ``env`` observes its glove
    (:func:`observe`: the same layout, float32 and bounds, and the target of the next step,
    whose time is the state's next step as in :meth:`GloveEnv.step`), the policy is called once
    on the (N, d) observations, and its (N, 3) actions, mapped to Pa as ``env`` maps them
    (:meth:`GloveEnv.physical_action`), pass ``env``'s safety limits from the
    feedback :meth:`GloveEnv.step` uses (:meth:`~exodigit_model.control.Feedback.of_state` with
    ``env.model``). So each glove of a noise-free batch is commanded, bit for bit, as a
    :class:`GloveEnv` is by the same policy (tests/test_control_batch.py).
    (:class:`~exodigit_model.control.BatchController` is the protocol.)

    Parameters
    ----------
    policy : callable
        ``policy(observations) -> actions``: float32 (N, d) to chamber pressure commands
        (N, 3) in ``env``'s action space (in [−1, 1] by default, Pa with
        ``action_scale='physical'``); e.g.
        ``lambda obs: agent.predict(obs, deterministic=True)[0]``.
    env : GloveEnv
        The environment the policy is for: its target, observation space and safety limits
        (``env.safety``; None: the actions go to the chambers unlimited). Its model estimates
        the contact forces the limiter checks: in a trial, make it on the nominal glove, the
        one a controller knows.

    Raises
    ------
    ValueError
        If ``policy`` is not callable.
    """

    def __init__(self, policy: Callable[[NDArray[np.float32]], ArrayLike], env: GloveEnv) -> None:
        if not callable(policy):
            raise ValueError(f'policy = {policy!r}: must be callable')
        self.policy, self.env = policy, env
        self._limiter = None if env.safety is None else SafetyLimiter(env.safety)
        self.last: Limited | None = None
        """The limiter's last answer (``acted``, (N, 5): the limits that acted per glove);
        None before the first, or without limits."""

    def reset(self, count: int, rng: np.random.Generator | None = None) -> None:
        """A new session of ``count`` gloves: the limiter forgets what it sent.

        ``rng`` is not used: a policy that draws random numbers keeps its own generator.
        """
        if self._limiter is not None:
            self._limiter.reset(count)
        self.last = None

    def command(self, t: float, dt: float, state: GloveState) -> NDArray[np.float64]:
        """The limited actions of every glove, Pa, (N, 3).

        Raises
        ------
        ValueError
            If the policy's actions are not finite or not one row of three per glove.
        """
        env = self.env
        target = env.target_of_step(state.step + 1) if env.observe_target else None
        observations, _ = observe(state, env.observation_space, target)
        actions = as_joint_rows('action', self.policy(observations))
        check_shape('action', actions, np.shape(state.q_measured))
        actions = env.physical_action(actions)
        if self._limiter is None:
            return actions
        feedback = Feedback.of_state(state, env.model)
        self.last = self._limiter.apply(actions, dt, feedback.angles, feedback.forces)
        return self.last.pressure


def _model(model: GloveModel | None, params: str | os.PathLike | GloveParams | None):
    """The GloveModel from ``model`` or ``params`` (at most one given), or a ValueError."""
    if model is not None and params is not None:
        raise ValueError('model and params: give one of them, not both')
    if model is not None:
        if not isinstance(model, GloveModel):
            raise ValueError(f'model = {model!r}: must be a GloveModel (or None)')
        return model
    if params is None or isinstance(params, GloveParams):
        return GloveModel(params)
    if isinstance(params, str | os.PathLike):
        return GloveModel(load_params(params))
    raise ValueError(f'params = {params!r}: must be a parameter file path or GloveParams')


if ENV_ID not in gymnasium.registry:
    gymnasium.register(id=ENV_ID, entry_point='exodigit_model.gym.env:GloveEnv')
