"""The population vector environment for Stable-Baselines3: :func:`sb3_vec_env`.

Stable-Baselines3 (the optional ``rl`` extra, ``pip install "./exodigit_model[rl]"``) steps
vectors of environments of its own ``VecEnv`` class, which resets an ended episode at once and
keeps the last observation in ``infos[i]['terminal_observation']``; it does not take a
Gymnasium ``VectorEnv``. :class:`PopulationVecEnv` is a
:class:`~exodigit_model.gym.vector.GloveVectorEnv` behind that protocol, written without
Stable-Baselines3; :func:`sb3_vec_env` makes it a subclass of SB3's ``VecEnv`` (importing
Stable-Baselines3 then, never before), which SB3's algorithms and wrappers (``VecNormalize``,
``VecMonitor``) take:

>>> from exodigit_model.gym.sb3 import sb3_vec_env
>>> from stable_baselines3 import PPO                                # doctest: +SKIP
>>> venv = sb3_vec_env(16, population='stroke_moderate')            # doctest: +SKIP
>>> PPO('MlpPolicy', venv).learn(100_000)                           # doctest: +SKIP
"""

from __future__ import annotations

from collections.abc import Iterable
from functools import cache
from typing import Any

import numpy as np
from gymnasium.vector import AutoresetMode
from numpy.typing import ArrayLike, NDArray

from .vector import GloveVectorEnv


class PopulationVecEnv:
    """:class:`~exodigit_model.gym.vector.GloveVectorEnv` with Stable-Baselines3's VecEnv API.

    ``reset() -> observations``; ``step_async(actions)`` then ``step_wait() -> (observations,
    rewards, dones, infos)`` with ``dones = terminated | truncated`` and ``infos`` a list of
    one dict per sub-environment. A sub-environment whose episode ends is reset in the same
    step (the vector environment's ``AutoresetMode.SAME_STEP``): the observation returned is the
    new episode's first, its info is the ended episode's last with
    ``'terminal_observation'`` (the last observation) and ``'TimeLimit.truncated'``
    (truncated, not terminated), and :attr:`reset_infos` holds the new episode's info.
    Every sub-environment is the vector environment's ``definition`` (a
    :class:`~exodigit_model.gym.env.GloveEnv`) on its own patient, so :meth:`get_attr` reads the
    definition; :meth:`set_attr` and :meth:`env_method` are refused, since the
    sub-environments are stepped together as one batch.

    Use :func:`sb3_vec_env` to hand it to Stable-Baselines3; this class is the protocol alone.

    Parameters
    ----------
    envs : GloveVectorEnv
        A vector environment made with ``autoreset_mode=AutoresetMode.SAME_STEP``.

    Raises
    ------
    ValueError
        If ``envs`` is not a GloveVectorEnv resetting in the same step.
    """

    def __init__(self, envs: GloveVectorEnv) -> None:
        if not isinstance(envs, GloveVectorEnv):
            raise ValueError(f'envs = {envs!r}: must be a GloveVectorEnv')
        mode = envs.metadata['autoreset_mode']
        if mode != AutoresetMode.SAME_STEP:
            raise ValueError(
                f'envs: autoreset_mode = {mode}: must be AutoresetMode.SAME_STEP, as '
                'Stable-Baselines3 resets (or use sb3_vec_env(num_envs, **keywords))'
            )
        self.envs = envs
        self.num_envs = envs.num_envs
        self.observation_space = envs.single_observation_space
        self.action_space = envs.single_action_space
        self.render_mode = None
        self.metadata: dict[str, Any] = {'render_modes': []}
        self.reset_infos: list[dict[str, Any]] = [{} for _ in range(self.num_envs)]
        self._seeds: list[int | None] = [None] * self.num_envs
        self._options: list[dict[str, Any]] = [{} for _ in range(self.num_envs)]
        self._actions: NDArray | None = None

    def seed(self, seed: int | None = None) -> list[int | None]:
        """The seed of the next :meth:`reset` (one generator draws every patient and noise)."""
        self._seeds = [seed] * self.num_envs
        return list(self._seeds)

    def set_options(self, options: list[dict] | dict | None = None) -> None:
        """Reset options; the glove takes none, so only empty ones are accepted."""
        for option in options if isinstance(options, list) else [options]:
            if option:
                raise ValueError(f'options = {options!r}: the glove takes no reset options')

    def reset(self) -> NDArray[np.float32]:
        """Reset every sub-environment (with the seed of :meth:`seed`, once)."""
        observations, infos = self.envs.reset(seed=self._seeds[0])
        self._seeds = [None] * self.num_envs
        self.reset_infos = _rows(infos, self.envs.info_keys, self.num_envs)
        return observations

    def step_async(self, actions: ArrayLike) -> None:
        """Remember ``actions`` ((num_envs, 3), or (num_envs, 6) behind valves) for step_wait."""
        self._actions = actions

    def step_wait(self) -> tuple[NDArray[np.float32], NDArray, NDArray[np.bool_], list[dict]]:
        """Step with the actions of :meth:`step_async`; see the class for ended episodes."""
        actions, self._actions = self._actions, None
        if actions is None:
            raise ValueError('step_wait() without step_async(actions) before it')
        observations, rewards, terminated, truncated, infos = self.envs.step(actions)
        dones = terminated | truncated
        keys, count = self.envs.info_keys, self.num_envs
        rows = _rows(infos, keys, count)
        if dones.any():
            last = _rows(infos['final_info'], keys, count)
            for row in np.flatnonzero(dones).tolist():
                self.reset_infos[row] = rows[row]
                rows[row] = last[row]
                rows[row]['terminal_observation'] = infos['final_obs'][row]
                rows[row]['TimeLimit.truncated'] = bool(truncated[row] and not terminated[row])
        return observations, rewards, dones, rows

    def step(
        self, actions: ArrayLike
    ) -> tuple[NDArray[np.float32], NDArray, NDArray[np.bool_], list[dict]]:
        """:meth:`step_async` then :meth:`step_wait`."""
        self.step_async(actions)
        return self.step_wait()

    def close(self) -> None:
        """Nothing to release: the gloves run in this process."""
        self.envs.close()

    def get_attr(self, attr_name: str, indices: Iterable[int] | int | None = None) -> list[Any]:
        """The definition's attribute ``attr_name``, once per index (AttributeError if none)."""
        value = getattr(self.envs.definition, attr_name)
        return [value for _ in self._indices(indices)]

    def set_attr(self, attr_name: str, value: Any, indices: Any = None) -> None:
        """Refused: the sub-environments share one definition, stepped as a batch."""
        raise ValueError(
            f'set_attr({attr_name!r}): the sub-environments share one GloveEnv definition; '
            'make a new vector environment with the keyword instead'
        )

    def env_method(self, method_name: str, *args: Any, indices: Any = None, **kwargs: Any):
        """Refused: the sub-environments are not separate environments to call."""
        raise ValueError(
            f'env_method({method_name!r}): the sub-environments are stepped as one batch; '
            'call the vector environment (.envs) instead'
        )

    def env_is_wrapped(self, wrapper_class: type, indices: Any = None) -> list[bool]:
        """No sub-environment is wrapped (``Monitor`` included: use SB3's ``VecMonitor``)."""
        return [False for _ in self._indices(indices)]

    def _indices(self, indices: Iterable[int] | int | None) -> list[int]:
        if indices is None:
            return list(range(self.num_envs))
        if isinstance(indices, int):
            return [indices]
        return list(indices)


def _rows(infos: dict[str, NDArray], keys: tuple[str, ...], count: int) -> list[dict]:
    """The vector environment's infos (arrays of ``count``) as one dict per sub-environment."""
    return [{key: infos[key][row] for key in keys} for row in range(count)]


def sb3_vec_env(envs: GloveVectorEnv | int, **keywords: Any) -> Any:
    """A Stable-Baselines3 ``VecEnv`` of the population: a :class:`PopulationVecEnv` that is one.

    Parameters
    ----------
    envs : GloveVectorEnv or int
        A vector environment made with ``autoreset_mode=AutoresetMode.SAME_STEP``, or the
        number of sub-environments of a new one.
    **keywords
        :class:`~exodigit_model.gym.vector.GloveVectorEnv`'s keywords for a new one
        (``population``, ``episode_steps``, ``safety``, ...), not with ``envs`` given.

    Raises
    ------
    ImportError
        Without Stable-Baselines3 (``pip install "./exodigit_model[rl]"``).
    ValueError
        For bad arguments, naming them.
    """
    if isinstance(envs, GloveVectorEnv):
        if keywords:
            raise ValueError(f'{", ".join(keywords)}: give a GloveVectorEnv or keywords, not both')
    else:
        envs = GloveVectorEnv(envs, autoreset_mode=AutoresetMode.SAME_STEP, **keywords)
    return _sb3_class()(envs)


@cache
def _sb3_class() -> type:
    """PopulationVecEnv as a subclass of Stable-Baselines3's VecEnv (imports SB3)."""
    try:
        from stable_baselines3.common.vec_env import VecEnv
    except ImportError as error:
        raise ImportError(
            'sb3_vec_env needs Stable-Baselines3: pip install "./exodigit_model[rl]"'
        ) from error

    class GloveSB3VecEnv(PopulationVecEnv, VecEnv):
        """:class:`PopulationVecEnv` as a Stable-Baselines3 ``VecEnv``."""

        def __init__(self, envs: GloveVectorEnv) -> None:
            PopulationVecEnv.__init__(self, envs)
            VecEnv.__init__(self, self.num_envs, self.observation_space, self.action_space)

    return GloveSB3VecEnv
