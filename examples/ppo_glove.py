"""Stable-Baselines3's PPO learns to move patients' fingers through the glove.

The task (docs/gym.md, "Learning with Stable-Baselines3"): ``exodigit/GlovePatients-v0`` with
``population='healthy'`` and otherwise its defaults. Each episode is one glove on a new patient
of the population, 4 s at 100 Hz, and the finger should follow a slow flex-extend (up to 28.9,
26.0, 17.1° at MCP, PIP, DIP, the nominal finger's angles at 50 kPa); the reward is
−Σ(q − q*)² per step, rad², so the return of an episode is 0 for perfect tracking. The agent
sees the measured angles, joint velocities, chamber pressures and the next target, and sends
three normalized pressures in [−1, 1] (0 to 60 kPa).

PPO (``MlpPolicy``, SB3's defaults but ``n_steps`` and ``batch_size``) trains on ``--envs``
gloves through the population adapter (:func:`exodigit_model.gym.sb3.sb3_vec_env`) with
``VecNormalize`` (the pressures are in Pa, the angles in rad). Every
``--timesteps``/``--evaluations`` steps the deterministic policy is scored on the same
``--patients`` held-out patients (one episode each; their draw does not change), beside four
fixed policies: the zero action (30 kPa in every chamber), vented chambers (−1), uniform random
actions and the open-loop pressure curve of docs/gym.md's first example. Printed: the learning
curve (env-steps, training wall seconds, mean and standard deviation of the return over the
patients) and the training speed; drawn: the curve to ``--plot``. SB3 learns in whole rollouts
(``--envs`` × ``--n-steps`` env-steps), so each stretch of training between evaluations is
rounded up to them. Torch runs on one thread (the machine is shared).

Needs the ``rl`` extra (docs/gym.md): ``pip install "./exodigit_model[rl]"``.
Run: ``python examples/ppo_glove.py [--timesteps 327680] [--plot ppo_learning_curve.png]``.
"""

import argparse
import time

import numpy as np
import torch
from exodigit_model.gym.sb3 import sb3_vec_env
from exodigit_model.gym.vector import GloveVectorEnv
from stable_baselines3 import PPO
from stable_baselines3.common.vec_env import VecMonitor, VecNormalize

EVALUATION_SEED = 12345
"""Seed of the held-out patients (training draws its own from ``--seed``)."""

OPEN_LOOP_PEAK = 50e3
"""Peak of docs/gym.md's open-loop example, Pa: 50 kPa · (1 − cos(2πt/4 s))/2."""


def evaluate(policy, population: str, patients: int) -> np.ndarray:
    """Each held-out patient's return of one episode under ``policy(observations, t)``."""
    envs = GloveVectorEnv(patients, population=population)
    observations, infos = envs.reset(seed=EVALUATION_SEED)
    returns = np.zeros(patients)
    for _ in range(envs.definition.episode_steps):
        observations, rewards, _, _, infos = envs.step(policy(observations, infos['t']))
        returns += rewards
    return returns


def baselines(population: str, patients: int, full_scale: float) -> dict[str, np.ndarray]:
    """The returns of the fixed policies, per held-out patient."""
    rng = np.random.default_rng(0)

    def open_loop(observations, t):
        pressure = OPEN_LOOP_PEAK * (1.0 - np.cos(2.0 * np.pi * t / 4.0)) / 2.0
        return np.repeat((2.0 * pressure / full_scale - 1.0)[:, None], 3, axis=1)

    policies = {
        'zero action': lambda observations, t: np.zeros((len(observations), 3)),
        'vented (-1)': lambda observations, t: -np.ones((len(observations), 3)),
        'random': lambda observations, t: rng.uniform(-1.0, 1.0, (len(observations), 3)),
        'open loop (docs)': open_loop,
    }
    return {name: evaluate(policy, population, patients) for name, policy in policies.items()}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split('\n', 1)[0])
    parser.add_argument('--timesteps', type=int, default=327_680, help='env-steps of training')
    parser.add_argument('--envs', type=int, default=16, help='gloves trained on at once')
    parser.add_argument('--n-steps', type=int, default=256, help="PPO's steps per env a rollout")
    parser.add_argument('--batch-size', type=int, default=256, help="PPO's minibatch size")
    parser.add_argument('--evaluations', type=int, default=10, help='points of the curve')
    parser.add_argument('--patients', type=int, default=32, help='held-out patients')
    parser.add_argument('--population', default='healthy', help='patients drawn from')
    parser.add_argument('--seed', type=int, default=0, help='PPO and training patients')
    parser.add_argument('--plot', default='ppo_learning_curve.png', help="PNG ('' for none)")
    options = parser.parse_args()
    torch.set_num_threads(1)

    venv = VecNormalize(VecMonitor(sb3_vec_env(options.envs, population=options.population)))
    venv.seed(options.seed)
    agent = PPO(
        'MlpPolicy',
        venv,
        n_steps=options.n_steps,
        batch_size=options.batch_size,
        seed=options.seed,
        device='cpu',
    )
    full_scale = float(venv.venv.venv.envs.definition.physical_action_space.high[0])
    fixed = baselines(options.population, options.patients, full_scale)

    def learned(observations, t):
        return agent.predict(venv.normalize_obs(observations), deterministic=True)[0]

    print(
        f'PPO on {options.envs} gloves of {options.population}; returns of one 4 s episode '
        f'on {options.patients} held-out patients, mean ± std, rad²·steps (0 is perfect)'
    )
    for name, returns in fixed.items():
        print(f'  {name:<17} {returns.mean():9.3f} ± {returns.std():.3f}')
    curve = [(0, 0.0, *_moments(evaluate(learned, options.population, options.patients)))]
    print(f'{"env-steps":>10} {"train s":>8} {"return":>9} {"std":>7}')
    print(f'{0:>10,} {0.0:>8.1f} {curve[0][2]:>9.3f} {curve[0][3]:>7.3f}')
    chunk = options.timesteps // options.evaluations
    trained = 0.0
    for _ in range(options.evaluations):
        start = time.perf_counter()
        agent.learn(chunk, reset_num_timesteps=False)
        trained += time.perf_counter() - start
        mean, std = _moments(evaluate(learned, options.population, options.patients))
        curve.append((agent.num_timesteps, trained, mean, std))
        print(f'{agent.num_timesteps:>10,} {trained:>8.1f} {mean:>9.3f} {std:>7.3f}')
    final = curve[-1][2]
    print(
        f'training: {agent.num_timesteps:,} env-steps in {trained:.1f} s wall, '
        f'{agent.num_timesteps / trained:,.0f} env-steps/s'
    )
    for name in ('zero action', 'random'):
        print(
            f'final return {final:.3f} vs {name} {fixed[name].mean():.3f}: '
            f'{fixed[name].mean() / final:.1f} times the squared error'
        )
    if options.plot:
        draw(curve, fixed, options)


def _moments(returns: np.ndarray) -> tuple[float, float]:
    return float(returns.mean()), float(returns.std())


def draw(curve, fixed, options) -> None:
    """The learning curve (mean ± std over the held-out patients) beside the fixed policies."""
    import matplotlib

    matplotlib.use('Agg')
    import matplotlib.pyplot as plt

    steps, _, mean, std = (np.array(column) for column in zip(*curve, strict=True))
    figure, axes = plt.subplots(figsize=(7, 4))
    axes.plot(steps, -mean, 'o-', label='PPO (deterministic)')
    axes.fill_between(steps, -(mean - std), -(mean + std), alpha=0.2)
    for name, returns in fixed.items():
        axes.axhline(-returns.mean(), linestyle='--', color=f'C{len(axes.lines)}', label=name)
    axes.set_yscale('log')
    axes.set_xlabel('env-steps of training')
    axes.set_ylabel('−return, rad²·steps (lower is better)')
    axes.set_title(f'PPO on exodigit/GlovePatients-v0, {options.patients} held-out patients')
    axes.legend(fontsize=8)
    figure.tight_layout()
    figure.savefig(options.plot, dpi=100)
    print(f'drawn: {options.plot}')


if __name__ == '__main__':
    main()
