"""Many simulated patients at once: :class:`GloveVectorEnv`, a Gymnasium ``VectorEnv``.

Each of ``num_envs`` sub-environments is a :class:`~exodigit_model.gym.env.GloveEnv` whose finger
is a patient drawn from a population (:mod:`exodigit_model.physics.populations`) at every reset:
domain randomisation over patients. The sub-environments step together on the batch stepper
(``GloveSimulation(model, settings, fingers=...)``, docs/spec/model.md §13), one glove per
patient, with ``GloveEnv``'s observation (:func:`~exodigit_model.gym.env.observe`), target, reward
and safety limiter.

Importing the module registers ``exodigit/GlovePatients-v0``: ``gymnasium.make_vec`` makes a
:class:`GloveVectorEnv`, ``gymnasium.make`` (and so Stable-Baselines3's ``make_vec_env``) one
glove on a new patient at every reset, :class:`GlovePatientEnv`:

>>> import gymnasium
>>> import exodigit_model.gym.vector
>>> envs = gymnasium.make_vec('exodigit/GlovePatients-v0', num_envs=8, episode_steps=50)
>>> observations, infos = envs.reset(seed=1)
>>> observations.shape, observations.dtype, envs.metadata['autoreset_mode'].name
((8, 12), dtype('float32'), 'NEXT_STEP')
>>> observations, rewards, terminated, truncated, infos = envs.step(envs.action_space.sample())
>>> rewards.shape, bool(truncated.any())
((8,), False)
"""

from __future__ import annotations

import os
from dataclasses import replace
from pathlib import Path
from typing import Any, ClassVar

import gymnasium
import numpy as np
from gymnasium.vector import AutoresetMode, VectorEnv
from gymnasium.vector.utils import batch_space
from numpy.typing import ArrayLike, NDArray

from ..control import LIMIT_KINDS, Feedback, SafetyLimiter, SafetyLimits
from ..control.shapes import check_shape
from ..physics.model import GloveModel, as_joint_rows
from ..physics.params import Finger, GloveParams
from ..physics.populations import Population, load_population
from ..stepping.settings import SimulationSettings
from ..stepping.simulation import GloveSimulation
from .env import (
    DEFAULT_EPISODE_STEPS,
    DEFAULT_SAFETY,
    SEED_BOUND,
    VALVE_INFO_KEYS,
    GloveEnv,
    Reward,
    Target,
    as_actions,
    observe,
)

AUTORESET_MODES = (AutoresetMode.NEXT_STEP, AutoresetMode.SAME_STEP)
"""The autoreset modes :class:`GloveVectorEnv` offers (not ``DISABLED``'s masked resets)."""

VECTOR_ENV_ID = 'exodigit/GlovePatients-v0'
"""The id under which importing this module registers :class:`GloveVectorEnv`."""

DEFAULT_POPULATION = 'stroke_moderate'
"""The population patients are drawn from by default (the glove's default patient's)."""

INFO_KEYS = (
    't',
    'target',
    'q',
    'pressure',
    'command',
    'safety',
    'converged',
    'in_valid_range',
    'observation_clipped',
)
"""The keys of every ``infos`` (each with its Gymnasium mask ``'_' + key``, all True); behind
valves also :data:`~exodigit_model.gym.env.VALVE_INFO_KEYS`."""


class GloveVectorEnv(VectorEnv):
    r"""``num_envs`` gloves, each on a patient drawn from a population at every reset.

    Sub-environment i is a :class:`~exodigit_model.gym.env.GloveEnv` (same action and observation
    spaces, target, reward, safety limiter, episode length and termination) whose finger is a
    patient of ``population``, drawn anew whenever the sub-environment resets; the glove (the
    exo-digit) is ``model``'s for every patient. The force estimate the limiter checks uses
    ``model``, the nominal glove, as on the ROS graph (it needs no finger model, so it is the
    patient's estimate too).

    Parameters
    ----------
    num_envs : int
        Number of sub-environments, >= 1.
    population : str, PathLike or Population, optional
        Where patients come from: a shipped population (``healthy``, ``stroke_mild``,
        ``stroke_moderate``, ``stroke_severe``), a population file (docs/populations.md) or a
        :class:`~exodigit_model.physics.populations.Population`; default
        :data:`DEFAULT_POPULATION`. Patients keep the link lengths of ``model``'s finger.
    model, params, settings, episode_steps, target, observe_target, safety, actuation, action_scale
        As :class:`~exodigit_model.gym.env.GloveEnv`'s, shared by every sub-environment: the target
        is a function of the time since the sub-environment's reset; behind valves
        (``actuation='valves'``) the actions are (num_envs, 6) openings and there is no
        limiter; actions are in [−1, 1] unless ``action_scale='physical'``.
    reward : callable, optional
        ``reward(state, target, actions) -> (n,)`` over a batch: the :class:`GloveState` of n
        gloves after the step (arrays (n, 3)), the target at ``state.t`` (rad, (3,)) and the
        physical actions (Pa, (n, 3), or openings (n, 6)). Default:
        :func:`~exodigit_model.gym.env.tracking_reward`, which takes one glove or a batch.
    autoreset_mode : AutoresetMode, optional
        ``AutoresetMode.NEXT_STEP`` (default) or ``AutoresetMode.SAME_STEP`` (see Notes).

    Notes
    -----
    **Autoreset** (``metadata['autoreset_mode']``): ``AutoresetMode.NEXT_STEP`` by default,
    Gymnasium's. The step that ends a sub-environment's episode (``terminated`` or
    ``truncated``) returns its last observation; the next step ignores that sub-environment's
    action, draws a new patient, and returns the first observation of the new episode with
    reward 0 and both flags False. With ``AutoresetMode.SAME_STEP`` (as Stable-Baselines3
    steps, :mod:`exodigit_model.gym.sb3`) the step that ends an episode draws the new patient
    at once and returns the new episode's first observation, with the step's reward and
    flags; ``infos['final_obs']`` (an object array, None where no episode ended, mask
    ``'_final_obs'``) holds the last observation and ``infos['final_info']`` the last infos,
    and ``infos`` of those sub-environments are their new episode's. Patients and noise seeds
    are drawn in the same order in both modes.

    **Seeding**: ``reset(seed=s)`` seeds :attr:`np_random`; every reset, the first and each
    autoreset, draws from it the seed of the patients it needs
    (``population.sample(count, seed)``) and the seed of their sensor noise, in that order.
    The same seed and actions give the same patients, observations and rewards, bit for bit.
    ``reset()`` without a seed continues from the generator.

    **Cohorts**: sub-environments that reset at the same step (at first all of them) share one
    batch simulation and limiter, so a cohort's gloves share the episode's clock as a
    ``GloveEnv``'s glove has its own. Noise-free, sub-environment i steps exactly as a
    ``GloveEnv`` on its patient (``model`` with ``finger=envs.fingers[i]``, the same target)
    fed the same actions, bit for bit. With sensor noise it is the same physics and noise law,
    but the noise is drawn for a cohort at once (docs of ``GloveSimulation``), so not the
    numbers of a one-glove ``GloveEnv``. A sub-environment that leaves its cohort early (a
    solve that did not converge) is stepped on with zero commands, unseen, until the whole
    cohort ends (behind valves: with every valve closed); every sub-environment truncates
    ``episode_steps`` after its reset.

    **Infos** (new arrays every call; keys :data:`INFO_KEYS`, each with its mask): ``t``
    (s since the sub-environment's reset), ``target`` (what the reward used), ``q`` and
    ``pressure`` (true), ``command`` (after the limiter and saturation), ``safety`` ((n, 5),
    whether each limit of :data:`~exodigit_model.control.LIMIT_KINDS` acted on the action),
    ``converged``, ``in_valid_range``, ``observation_clipped``; behind valves ``mass`` and
    ``volume`` ((n, 3), kg and m³). :attr:`fingers` holds every
    sub-environment's patient.
    """

    metadata: ClassVar[dict[str, Any]] = {
        'autoreset_mode': AutoresetMode.NEXT_STEP,
        'render_modes': [],
    }

    def __init__(
        self,
        num_envs: int,
        *,
        population: str | os.PathLike | Population = DEFAULT_POPULATION,
        model: GloveModel | None = None,
        params: str | os.PathLike | GloveParams | None = None,
        settings: SimulationSettings | None = None,
        episode_steps: int = DEFAULT_EPISODE_STEPS,
        target: Target | None = None,
        reward: Reward | None = None,
        observe_target: bool = True,
        safety: SafetyLimits | None = DEFAULT_SAFETY,
        actuation: str = 'regulator',
        action_scale: str = 'normalized',
        autoreset_mode: AutoresetMode = AutoresetMode.NEXT_STEP,
    ) -> None:
        if autoreset_mode not in AUTORESET_MODES:
            raise ValueError(
                f'autoreset_mode = {autoreset_mode!r}: must be one of '
                f'{", ".join(str(mode) for mode in AUTORESET_MODES)}'
            )
        if isinstance(num_envs, bool) or not isinstance(num_envs, int | np.integer):
            raise ValueError(f'num_envs = {num_envs!r}: must be an integer')
        if num_envs < 1:
            raise ValueError(f'num_envs = {num_envs!r}: must be >= 1')
        if isinstance(population, str | os.PathLike):
            population = load_population(
                population if isinstance(population, str) else Path(population)
            )
        elif not isinstance(population, Population):
            raise ValueError(
                f'population = {population!r}: must be a population name, file or Population'
            )
        self.population = population
        self.definition = GloveEnv(
            model,
            params=params,
            settings=settings,
            episode_steps=episode_steps,
            target=target,
            reward=reward,
            observe_target=observe_target,
            safety=safety,
            actuation=actuation,
            action_scale=action_scale,
        )
        """The GloveEnv every sub-environment is, on its patient (its checks, spaces, target,
        reward and limits; never stepped)."""
        self.num_envs = int(num_envs)
        self.metadata = {**self.metadata, 'autoreset_mode': autoreset_mode}
        self.model = self.definition.model
        self.single_action_space = self.definition.action_space
        self.single_observation_space = self.definition.observation_space
        self.action_space = batch_space(self.single_action_space, self.num_envs)
        self.observation_space = batch_space(self.single_observation_space, self.num_envs)
        self.info_keys = INFO_KEYS + (VALVE_INFO_KEYS if self.definition.valves else ())
        """The keys of every ``infos``."""
        self.fingers: list[Finger | None] = [None] * self.num_envs
        """Each sub-environment's patient (None before the first reset)."""
        self._cohorts: list[_Cohort] = []
        self._ended = np.zeros(self.num_envs, bool)

    def reset(
        self, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[NDArray[np.float32], dict[str, Any]]:
        """Start every sub-environment's episode on a new patient.

        Parameters
        ----------
        seed : int, optional
            Seeds :attr:`np_random`, from which the patients and noise seeds are drawn.
        options : dict, optional
            No options exist; an empty dict or None.

        Returns
        -------
        observations : ndarray of float32, (num_envs, d)
        infos : dict
        """
        if seed is not None and (isinstance(seed, bool) or not isinstance(seed, int)):
            raise ValueError(f'seed = {seed!r}: must be an integer (or None)')
        if options:
            raise ValueError(f'options = {options!r}: GloveVectorEnv takes no reset options')
        super().reset(seed=seed)
        self._cohorts = [self._enrol(np.arange(self.num_envs))]
        self._ended = np.zeros(self.num_envs, bool)
        observations, _, _, _, infos = self._gather()
        return observations, infos

    def step(
        self, actions: ArrayLike
    ) -> tuple[
        NDArray[np.float32], NDArray[np.float64], NDArray[np.bool_], NDArray[np.bool_], dict
    ]:
        """Apply ``actions``: pressure commands (num_envs, 3), or openings (num_envs, 6).

        In [−1, 1] by default, in Pa (openings in [0, 1]) with ``action_scale='physical'``.
        With ``NEXT_STEP`` autoreset, sub-environments whose episode ended at the last step are
        reset instead (their actions are not used); with ``SAME_STEP`` those whose episode
        ends at this step are reset at its end.

        Returns
        -------
        observations : ndarray of float32, (num_envs, d)
        rewards : ndarray of float64, (num_envs,)
        terminations : ndarray of bool, (num_envs,)
            The sub-environment's solve did not converge in this step.
        truncations : ndarray of bool, (num_envs,)
            This step completed the sub-environment's ``episode_steps``.
        infos : dict

        Raises
        ------
        ValueError
            If ``actions`` is not (num_envs, 3) (behind valves (num_envs, 6)) finite numbers,
            or ``target``/``reward`` return something that is not three finite angles / n
            finite numbers.
        gymnasium.error.ResetNeeded
            Before the first :meth:`reset`.
        """
        if not self._cohorts:
            raise gymnasium.error.ResetNeeded('GloveVectorEnv: call reset() before step()')
        if self.definition.valves:
            actions = as_actions('actions', actions, self.action_space.shape)
        else:
            actions = as_joint_rows('actions', actions)
            check_shape('actions', actions, (self.num_envs, 3))
        actions = self.definition.physical_action(actions)
        restarting = np.flatnonzero(self._ended)
        for cohort in self._cohorts:
            cohort.leave(self._ended)
        self._cohorts = [cohort for cohort in self._cohorts if cohort.members.any()]
        for cohort in self._cohorts:
            cohort.step(actions)
        if restarting.size:
            self._cohorts.append(self._enrol(restarting))
        result = self._gather()
        self._ended = result[2] | result[3]
        if self.metadata['autoreset_mode'] == AutoresetMode.SAME_STEP and self._ended.any():
            return self._reset_ended(*result)
        return result

    # -- helpers ---------------------------------------------------------------------------

    def _enrol(self, rows: NDArray[np.intp]) -> _Cohort:
        """A new cohort: the sub-environments ``rows`` on new patients, at rest."""
        patient_seed, noise_seed = (
            int(seed) for seed in self.np_random.integers(SEED_BOUND, size=2)
        )
        patients = self.population.sample(
            len(rows), patient_seed, base=self.model.params.finger
        ).fingers
        for row, finger in zip(rows.tolist(), patients, strict=True):
            self.fingers[row] = finger
        return _Cohort(self.definition, rows, patients, noise_seed)

    def _reset_ended(self, observations, rewards, terminated, truncated, infos) -> tuple:
        """SAME_STEP: the ended sub-environments' new episodes, their last in ``final_*``."""
        ended, self._ended = self._ended, np.zeros(self.num_envs, bool)
        for cohort in self._cohorts:
            cohort.leave(ended)
        self._cohorts = [cohort for cohort in self._cohorts if cohort.members.any()]
        self._cohorts.append(self._enrol(np.flatnonzero(ended)))
        started, *_, new_infos = self._gather()
        final = np.full(self.num_envs, None, object)
        for row in np.flatnonzero(ended).tolist():
            final[row] = observations[row]
        new_infos['final_obs'], new_infos['_final_obs'] = final, ended
        new_infos['final_info'], new_infos['_final_info'] = infos, ended.copy()
        return started, rewards, terminated, truncated, new_infos

    def _gather(self) -> tuple:
        """Every sub-environment's last outcome, from the cohort it belongs to."""
        cohorts = self._cohorts
        whole = len(cohorts) == 1 and len(cohorts[0].rows) == self.num_envs
        if whole and cohorts[0].in_order and cohorts[0].members.all():
            # Every sub-environment in one cohort, in order (until the first autoreset): the
            # same arrays, copied whole instead of row by row.
            gathered = {key: np.array(value) for key, value in cohorts[0].outcome.items()}
        else:
            gathered: dict[str, NDArray] = {}
            for cohort in cohorts:
                live = cohort.members
                rows = cohort.rows[live]
                for key, value in cohort.outcome.items():
                    if key not in gathered:
                        shape = (self.num_envs, *value.shape[1:])
                        gathered[key] = np.empty(shape, value.dtype)
                    gathered[key][rows] = value[live]
        infos = {}
        for key in self.info_keys:
            infos[key] = gathered[key]
            infos[f'_{key}'] = np.ones(self.num_envs, bool)
        return (
            gathered['observation'],
            gathered['reward'],
            gathered['terminated'],
            gathered['truncated'],
            infos,
        )


class _Cohort:
    """Sub-environments that reset at one step: one batch simulation and limiter, one clock.

    ``rows`` are the sub-environments of the gloves, ``members`` whether each glove's
    sub-environment is still in this cohort (one that ended and reset has left it; its glove
    is stepped on with zero commands, unseen). ``outcome`` is the last reset or step, per glove.
    """

    def __init__(
        self, definition: GloveEnv, rows: NDArray[np.intp], fingers, noise_seed: int
    ) -> None:
        self.definition, self.rows = definition, rows
        self.in_order = bool(np.array_equal(rows, np.arange(len(rows))))
        """Whether ``rows`` are the sub-environments 0, 1, … in order."""
        self.members = np.ones(len(rows), bool)
        settings = replace(definition.settings, seed=noise_seed)
        self.simulation = GloveSimulation(
            definition.model, settings, fingers=fingers, actuation=definition.actuation
        )
        safety, count = definition.safety, len(rows)
        self.limiter = None if safety is None else SafetyLimiter(safety, count=count)
        self.next_target = definition.target_of_step(1)
        zeros = np.zeros(count)
        self.outcome = self._outcome(
            definition.target_of_step(0), zeros, np.zeros((count, len(LIMIT_KINDS)), bool)
        )
        self.outcome['terminated'] = self.outcome['truncated'] = np.zeros(count, bool)

    def leave(self, ended: NDArray[np.bool_]) -> None:
        """Let the sub-environments whose episode ``ended`` (per sub-environment) leave."""
        self.members &= ~ended[self.rows]

    def step(self, actions: NDArray[np.float64]) -> None:
        """One step of every glove: the members' ``actions`` rows through the limiter."""
        definition, state = self.definition, self.simulation.state
        desired = np.where(self.members[:, None], actions[self.rows], 0.0)
        command, acted = desired, np.zeros((len(self.rows), len(LIMIT_KINDS)), bool)
        if self.limiter is not None:
            feedback = Feedback.of_state(state, definition.model)
            limited = self.limiter.apply(
                desired, self.simulation.period, feedback.angles, feedback.forces
            )
            command, acted = limited.pressure, limited.acted
        state = self.simulation.step(command)
        target = self.next_target
        reward = np.asarray(definition.reward(state, target.copy(), desired.copy()), float)
        if reward.shape != self.members.shape or not np.all(np.isfinite(reward[self.members])):
            raise ValueError(
                f'reward returned {reward!r} at t = {state.t} s: must be {len(self.rows)} '
                'finite numbers, one per glove'
            )
        self.next_target = definition.target_of_step(state.step + 1)
        self.outcome = self._outcome(target, reward, acted)
        self.outcome['terminated'] = ~state.converged
        self.outcome['truncated'] = np.full(len(self.rows), state.step >= definition.episode_steps)

    def _outcome(
        self, target: NDArray[np.float64], reward: NDArray[np.float64], acted: NDArray[np.bool_]
    ) -> dict[str, NDArray]:
        """Observations, rewards and the info arrays of the simulation's state, per glove."""
        definition, state = self.definition, self.simulation.state
        observed = self.next_target if definition.observe_target else None
        observation, clipped = observe(state, definition.observation_space, observed)
        count = len(self.rows)
        valves = {key: getattr(state, key) for key in VALVE_INFO_KEYS if definition.valves}
        return {
            'observation': observation,
            'reward': reward,
            't': np.full(count, state.t),
            'target': np.broadcast_to(target, (count, 3)),
            'q': state.q,
            'pressure': state.pressure,
            'command': state.command,
            'safety': acted,
            'converged': state.converged,
            'in_valid_range': state.in_valid_range,
            'observation_clipped': clipped,
            **valves,
        }


class GlovePatientEnv(gymnasium.Env):
    """One glove on a patient drawn from a population at every reset: a GloveVectorEnv of one.

    What ``gymnasium.make('exodigit/GlovePatients-v0')`` makes, so that libraries that build
    their vector of environments from single ones (Stable-Baselines3's ``make_vec_env``,
    ``gymnasium.vector.SyncVectorEnv``) get the population too. Every keyword is
    :class:`GloveVectorEnv`'s but ``num_envs`` and ``autoreset_mode``; the spaces are its
    single spaces.

    ``reset(seed=s)`` seeds :attr:`np_random`; every reset draws from it the seed of the
    :class:`GloveVectorEnv` of one glove it resets (:attr:`patients`), so equal seeds give
    equal sequences of patients and episodes. ``info`` has the keys of
    :data:`INFO_KEYS` (behind valves also ``mass`` and ``volume``), one glove's values, and
    ``safety`` is the tuple of the limits of :data:`~exodigit_model.control.LIMIT_KINDS` that
    acted on the action. After an episode ends, call :meth:`reset`.
    """

    metadata: ClassVar[dict[str, Any]] = {'render_modes': []}

    def __init__(self, **kwargs: Any) -> None:
        for name in ('num_envs', 'autoreset_mode'):
            if name in kwargs:
                raise ValueError(f'{name} = {kwargs[name]!r}: GlovePatientEnv is one glove')
        self.patients = GloveVectorEnv(1, **kwargs)
        """The vector environment of the one glove."""
        self.action_space = self.patients.single_action_space
        self.observation_space = self.patients.single_observation_space

    @property
    def finger(self) -> Finger | None:
        """The patient of the current episode (None before the first reset)."""
        return self.patients.fingers[0]

    def reset(
        self, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[NDArray[np.float32], dict[str, Any]]:
        """Start an episode at rest on a new patient (see the class)."""
        super().reset(seed=seed)
        observations, infos = self.patients.reset(
            seed=int(self.np_random.integers(SEED_BOUND)), options=options
        )
        return observations[0], self._info(infos)

    def step(
        self, action: ArrayLike
    ) -> tuple[NDArray[np.float32], float, bool, bool, dict[str, Any]]:
        """Apply ``action``, as :meth:`GloveEnv.step <exodigit_model.gym.env.GloveEnv.step>`."""
        try:
            actions = np.asarray(action, dtype=float)[None]
        except (TypeError, ValueError):
            actions = action  # refused by the vector environment, naming it
        observations, rewards, terminated, truncated, infos = self.patients.step(actions)
        return (
            observations[0],
            float(rewards[0]),
            bool(terminated[0]),
            bool(truncated[0]),
            self._info(infos),
        )

    def _info(self, infos: dict[str, NDArray]) -> dict[str, Any]:
        info = {key: infos[key][0] for key in self.patients.info_keys}
        for key in ('t', 'converged', 'in_valid_range', 'observation_clipped'):
            info[key] = info[key].item()
        info['safety'] = tuple(
            kind for kind, acted in zip(LIMIT_KINDS, info['safety'], strict=True) if acted
        )
        return info


if VECTOR_ENV_ID not in gymnasium.registry:
    gymnasium.register(
        id=VECTOR_ENV_ID,
        entry_point='exodigit_model.gym.vector:GlovePatientEnv',
        vector_entry_point='exodigit_model.gym.vector:GloveVectorEnv',
    )
