"""Speed of GloveVectorEnv (issue 17, item 6: >= 500,000 env-steps/s at 1,000 sub-environments).

``GloveVectorEnv(--envs)`` on ``--population`` steps ``--steps`` times (default 802: two
episodes of 400 steps and their two autoreset steps, so the patients' draws and the new
cohorts' rest solves are counted) under random actions in [0, 100 kPa] (``action_scale=
'physical'``), once behind the ``pressure_command`` node's limiter (``NODE_SAFETY``, which needs
the robot-side force estimate of every glove at every step) and once with ``safety=None``, the
two taking turns ``--repeats`` times. With ``--valves`` a third kind
takes its turn too: ``actuation='valves'`` (docs/spec/model.md §14) under random openings in
[0, 1] (six per glove; no limiter), so the two actuations are measured in one run, side by
side. Env-steps count what Gymnasium's ``utils.performance.benchmark_vector_step`` counts for
NEXT_STEP autoreset: every sub-environment that stepped, not those being reset. Printed:
env-steps per CPU second (``process_time``; the machine is a shared VM) and per wall second, the
median and the range, then a profile of one run with the limiter, where the time goes.

Run ``python -m exodigit_model.tools.warm`` first, so that no kernel compiles here.
Run: ``.venv/bin/python benchmarks/bench_gym_vector.py [--envs 1000] [--repeats 5] [--valves]``.
"""

import argparse
import cProfile
import gc
import pstats
import statistics
import time

import numpy as np
from exodigit_model.gym.env import NODE_SAFETY
from exodigit_model.gym.vector import GloveVectorEnv

SUPPLY = 100e3
"""Actions are drawn in [0, this], Pa (the default supply)."""


def timed(envs: GloveVectorEnv, actions: np.ndarray, seed: int) -> tuple[float, float, int]:
    """(CPU s, wall s, env-steps) of one reset and one step per row of ``actions``, GC off."""
    envs.reset(seed=seed)
    stepped, resetting = 0, np.zeros(envs.num_envs, bool)
    gc.disable()
    try:
        cpu, wall = time.process_time(), time.perf_counter()
        for action in actions:
            _, _, terminated, truncated, _ = envs.step(action)
            stepped += envs.num_envs - int(np.count_nonzero(resetting))
            resetting = terminated | truncated
        cpu, wall = time.process_time() - cpu, time.perf_counter() - wall
    finally:
        gc.enable()
    return cpu, wall, stepped


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split('\n', 1)[0])
    parser.add_argument('--envs', type=int, default=1000, help='sub-environments')
    parser.add_argument('--steps', type=int, default=802, help='vector steps per run')
    parser.add_argument('--repeats', type=int, default=5, help='runs of each kind')
    parser.add_argument('--population', default='stroke_moderate', help='patients drawn from')
    parser.add_argument(
        '--valves', action='store_true', help="also actuation='valves' under random openings"
    )
    options = parser.parse_args()
    rng = np.random.default_rng(0)
    pressures = rng.uniform(0.0, SUPPLY, (options.steps, options.envs, 3))
    common = {'population': options.population, 'action_scale': 'physical'}
    kinds = {
        'limiter': (GloveVectorEnv(options.envs, safety=NODE_SAFETY, **common), pressures),
        'safety=None': (GloveVectorEnv(options.envs, safety=None, **common), pressures),
    }
    if options.valves:
        openings = rng.uniform(0.0, 1.0, (options.steps, options.envs, 6))
        envs = GloveVectorEnv(options.envs, actuation='valves', **common)
        kinds['valves'] = (envs, openings)
    for envs, actions in kinds.values():
        timed(envs, actions[:2], 0)  # first use of every kernel and array
    rates = {kind: ([], []) for kind in kinds}
    for repeat in range(options.repeats):
        for kind, (envs, actions) in kinds.items():
            cpu, wall, stepped = timed(envs, actions, repeat)
            rates[kind][0].append(stepped / cpu)
            rates[kind][1].append(stepped / wall)
    print(
        f'GloveVectorEnv, {options.envs} sub-environments of {options.population}, '
        f'{options.steps} steps, {options.repeats} runs: env-steps/s median [min, max]'
    )
    for kind, (cpu, wall) in rates.items():
        print(
            f'  {kind:<12} CPU {statistics.median(cpu):>9,.0f} [{min(cpu):,.0f}, {max(cpu):,.0f}]'
            f'   wall {statistics.median(wall):>9,.0f} [{min(wall):,.0f}, {max(wall):,.0f}]'
        )
    profile = cProfile.Profile()
    profile.runcall(timed, *kinds['limiter'], 0)
    pstats.Stats(profile).sort_stats('tottime').print_stats(8)


if __name__ == '__main__':
    main()
