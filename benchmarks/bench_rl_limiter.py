"""How often the safety limiter changes a random action (issue 38, item 2; docs/gym.md).

Random actions, uniform in [−1, 1] per chamber (what an untrained policy of an RL library
sends), drive ``GloveVectorEnv(--envs)`` of ``--population`` for ``--episodes`` default
episodes of 400 steps, once behind the environments' default limits (``DEFAULT_SAFETY``: the
``pressure_command`` node's without the rate limit) and once behind the node's own
(``NODE_SAFETY``), ``--repeats`` seeds each. Printed per limits: the share of env-steps on which
any limit acted, then per limit of ``LIMIT_KINDS``, as the median and [min, max] over seeds.
Every sub-environment of the vector environment is a ``GloveEnv`` on its patient
(tests/test_model_gym_vector.py), so these are the one-glove environment's shares too.

Run: ``.venv/bin/python benchmarks/bench_rl_limiter.py [--envs 256] [--repeats 3]``.
"""

import argparse
import statistics

import numpy as np
from exodigit_model.control import LIMIT_KINDS
from exodigit_model.gym.env import DEFAULT_SAFETY, NODE_SAFETY
from exodigit_model.gym.vector import GloveVectorEnv


def acted_shares(envs: GloveVectorEnv, steps: int, seed: int) -> np.ndarray:
    """Per limit of LIMIT_KINDS and for any (last column): the share of env-steps it acted on."""
    envs.reset(seed=seed)
    rng = np.random.default_rng(seed)
    counts, stepped = np.zeros(len(LIMIT_KINDS) + 1), 0
    resetting = np.zeros(envs.num_envs, bool)
    for _ in range(steps):
        actions = rng.uniform(-1.0, 1.0, envs.action_space.shape)
        _, _, terminated, truncated, infos = envs.step(actions)
        acted = infos['safety'][~resetting]
        counts[:-1] += acted.sum(axis=0)
        counts[-1] += acted.any(axis=1).sum()
        stepped += int(np.count_nonzero(~resetting))
        resetting = terminated | truncated
    return counts / stepped


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split('\n', 1)[0])
    parser.add_argument('--envs', type=int, default=256, help='sub-environments')
    parser.add_argument('--episodes', type=int, default=2, help='episodes of each')
    parser.add_argument('--repeats', type=int, default=3, help='seeds of each limits')
    parser.add_argument('--population', default='stroke_moderate', help='patients drawn from')
    options = parser.parse_args()
    for name, limits in (('DEFAULT_SAFETY', DEFAULT_SAFETY), ('NODE_SAFETY', NODE_SAFETY)):
        envs = GloveVectorEnv(options.envs, population=options.population, safety=limits)
        steps = options.episodes * (envs.definition.episode_steps + 1) - 1
        shares = np.array([acted_shares(envs, steps, seed) for seed in range(options.repeats)])
        print(
            f'{name}: {options.envs} gloves of {options.population}, {options.episodes} '
            f'episodes of random actions in [-1, 1], {options.repeats} seeds: '
            'share of env-steps limited, median [min, max]'
        )
        for column, kind in enumerate((*LIMIT_KINDS, 'any')):
            values = shares[:, column] * 100.0
            print(
                f'  {kind:<11} {statistics.median(values):8.3f} % '
                f'[{values.min():.3f}, {values.max():.3f}]'
            )


if __name__ == '__main__':
    main()
