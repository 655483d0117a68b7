"""Speed of a batch of gloves on a population of patients (issue 17, item 4), printed as figures.

One ``GloveSimulation(model, fingers=...)`` steps ``--patients`` gloves (default 10,000), each
its own phase of a sine command 0-40 kPa, ``--steps`` timed steps (default 300) after 20 that
settle the chambers, on three kinds of batch built in the same run:

a. distinct patients: ``load_population(--population).sample(N, seed).fingers``;
b. identical patients: the population's preset finger N times (the same physics as a, at the
   centre of the population, through the same per-glove finger rows);
c. today's batch: ``count=N`` on the nominal finger (no spasticity, no range-of-motion terms).

Each is measured ``--repeats`` times, the three taking turns, in glove-steps per CPU second
(``process_time``; the machine is a shared VM) and per wall second: the median and the range.
Also printed: what each batch costs to set up (drawing the patients, making their Fingers, the
rest solve of every glove) and the mean Newton iterations per glove-step, which tell the
patients' physics from the cost of per-glove parameters. [issue 17: a whole trial, stepper +
controller + metrics, >= 700,000 glove-steps/s on one core, so the stepper well above that]

Run ``python -m exodigit_model.tools.warm`` first, so that no kernel compiles here.
Run: ``.venv/bin/python benchmarks/bench_population.py [--patients 10000] [--steps 300]``.
"""

import argparse
import gc
import statistics
import time

import numpy as np
from exodigit_model.kernels import jit
from exodigit_model.trials import load_population

from exodigit_model import GloveModel, GloveSimulation, load_params, patient_file

SETTLE_STEPS = 20
"""Untimed steps before the timed ones (four chamber time constants at 100 Hz)."""
PERIOD = 400
"""Steps of one period of the sine command."""


def sine(count: int, steps: int) -> np.ndarray:
    """Commands (steps, count, 3), Pa: 20 kPa (1 - cos), glove i at phase 2πi/count."""
    phases = np.linspace(0.0, 2.0 * np.pi, count, endpoint=False)
    k = np.arange(steps)[:, None]
    rows = 20e3 * (1.0 - np.cos(2.0 * np.pi * k / PERIOD + phases))
    return np.ascontiguousarray(np.repeat(rows[:, :, None], 3, axis=2))


def batches(model: GloveModel, population: str, count: int, seed: int) -> dict:
    """The three batches of the module docstring, and the seconds each took to set up."""
    made = {}
    began = time.perf_counter()
    fingers = load_population(population).sample(count, seed).fingers
    made['distinct'] = (GloveSimulation(model, fingers=fingers), time.perf_counter() - began)
    began = time.perf_counter()
    preset = load_params(patient_file(population)).finger
    made['identical'] = (
        GloveSimulation(model, fingers=[preset] * count),
        time.perf_counter() - began,
    )
    began = time.perf_counter()
    made['nominal'] = (GloveSimulation(model, count=count), time.perf_counter() - began)
    return made


def timed(simulation: GloveSimulation, commands: np.ndarray) -> tuple[float, float, float]:
    """(CPU s, wall s, mean Newton iterations) of one step per row of ``commands``, GC off."""
    iterations = 0
    gc.disable()
    try:
        cpu, wall = time.process_time(), time.perf_counter()
        for command in commands:
            iterations += int(simulation.step(command).iterations.sum())
        cpu, wall = time.process_time() - cpu, time.perf_counter() - wall
    finally:
        gc.enable()
    return cpu, wall, iterations / (len(commands) * simulation.count)


def main() -> None:
    parser = argparse.ArgumentParser(
        description=__doc__.splitlines()[0],
        epilog='The module docstring says what each figure measures and its target.',
    )
    parser.add_argument('--patients', type=int, default=10_000, help='gloves (default 10,000)')
    parser.add_argument('--steps', type=int, default=300, help='timed steps (default 300)')
    parser.add_argument('--repeats', type=int, default=3, help='measurements (default 3)')
    parser.add_argument(
        '--population', default='stroke_moderate', help='shipped population (default %(default)s)'
    )
    parser.add_argument('--seed', type=int, default=1, help='seed of the patients (default 1)')
    args = parser.parse_args()
    if min(args.patients, args.steps, args.repeats) < 1:
        parser.error('--patients, --steps and --repeats must be >= 1')
    count = args.patients
    model = GloveModel()
    GloveSimulation(model, count=2).step(np.zeros((2, 3)))  # load the kernels (not timed)
    made = batches(model, args.population, count, args.seed)
    commands = sine(count, SETTLE_STEPS + args.repeats * args.steps)
    rates = {name: {'cpu': [], 'wall': []} for name in made}
    iterations = {}
    for simulation, _ in made.values():
        for command in commands[:SETTLE_STEPS]:
            simulation.step(command)
    for repeat in range(args.repeats):
        start = SETTLE_STEPS + repeat * args.steps
        for name, (simulation, _) in made.items():
            cpu, wall, iterations[name] = timed(simulation, commands[start : start + args.steps])
            rates[name]['cpu'].append(count * args.steps / cpu)
            rates[name]['wall'].append(count * args.steps / wall)
    path = 'compiled' if jit.JIT else 'NOT compiled (numba missing or EXODIGIT_JIT=0)'
    print(
        f'{count:,} gloves x {args.steps} steps (after {SETTLE_STEPS}), each its own phase of a '
        f'sine 0-40 kPa, {args.repeats} repeats taking turns; kernels {path}, source digest '
        f'{jit.source_digest()}'
    )
    labels = {
        'distinct': f'a. {count:,} distinct {args.population} patients (seed {args.seed})',
        'identical': f'b. the {args.population} preset {count:,} times',
        'nominal': f'c. count={count:,}, the nominal finger',
    }
    for name, (simulation, setup) in made.items():
        cpu, wall = rates[name]['cpu'], rates[name]['wall']
        print(
            f'{labels[name]}: {statistics.median(cpu):,.0f} glove-steps/s CPU '
            f'({min(cpu):,.0f}-{max(cpu):,.0f}), {statistics.median(wall):,.0f}/s wall; '
            f'set-up {setup:.2f} s; {iterations[name]:.3f} Newton iterations per glove-step; '
            f'solver failures {simulation.solver_failures}'
        )
    ratio = statistics.median(rates['distinct']['cpu']) / statistics.median(
        rates['identical']['cpu']
    )
    print(
        f'distinct / identical patients: {ratio:.2f} of the speed (CPU medians)  '
        '[stepper well above 700,000 glove-steps/s]'
    )


if __name__ == '__main__':
    main()
