"""Cost per step of the built-in controllers and the safety limiter over a batch of gloves.

A virtual-patient trial (issue 17) steps 10,000 gloves as one batch at >= 700,000 glove-steps/s,
controller included: about 14 ms a step for everything, so the controller gets a few ms; each
line ends with its share of that (``[n % of the trial's step]``). This prints, per mode, the
time of one ``CommandLoop.command`` (the controller and the limiter: what ``BuiltInMode`` adds
per step besides the feedback), then the feedback itself: the nominal model's robot-side force
estimate of the batch (``Feedback.of_state`` with an estimator, what the force mode and the
limiter's contact-force check need) and a whole ``BuiltInMode`` step with it, and
``PolicyController`` around a policy that costs nothing.

Run ``python -m exodigit_model.tools.warm`` first (``make bench`` does), then
``.venv/bin/python benchmarks/bench_control.py`` (``--help``: the options). The feedback is a
batch of gloves on the nominal model after a short staircase (states inside the range of
motion). Each figure: ``--steps`` calls timed as one loop, ``--repeats`` times, after one
untimed call (it loads the compiled force feed-forward); the CPU time per call of each repeat
(``process_time``), printed as the median and the range over the repeats, and the wall-time
median beside it (a shared 2-core VM: other work runs beside it). The garbage collector is off
while timing.
"""

from __future__ import annotations

import argparse
import gc
import statistics
import time
from collections.abc import Callable

import numpy as np
from exodigit_model.control import (
    BuiltInMode,
    CommandLoop,
    Feedback,
    ForceController,
    Hold,
    PositionController,
    SafetyLimiter,
    SafetyLimits,
    Sine,
    Staircase,
)
from exodigit_model.gym.env import GloveEnv, PolicyController

from exodigit_model import GloveModel, GloveSimulation

DT = 0.01
"""The step, s (100 Hz)."""
TRIAL_RATE = 700_000
"""The trial's target, glove-steps/s, controller and stepper included (issue 17)."""


def modes(model: GloveModel, count: int) -> dict[str, Callable[[], object]]:
    """Each built-in mode with the node's default parameters, made for ``count`` gloves."""
    return {
        'staircase': lambda: Staircase(10e3, 50e3, 2.0),
        'sine': lambda: Sine(0.0, 40e3, 4.0),
        'hold': lambda: Hold(np.full(3, 20e3)),
        'position': lambda: PositionController(model, [0.3, 0.3, 0.2], 5e4, 3e5, count=count),
        'force': lambda: ForceController(model, [0.1, 0.1, 0.1], 5e4, 5e5, count=count),
    }


def batch_state(model: GloveModel, count: int):
    """The state of ``count`` gloves after a staircase of 20 steps to 20-35 kPa."""
    simulation = GloveSimulation(model, count=count)
    levels = np.linspace([20e3, 25e3, 30e3], [30e3, 35e3, 25e3], count)
    for fraction in np.linspace(0.05, 1.0, 20):
        state = simulation.step(fraction * levels)
    return state


def time_calls(call: Callable[[int], object], steps: int, repeats: int) -> tuple[list, list]:
    """CPU and wall seconds per call of ``call(step)``, one pair per repeat."""
    call(0)
    cpu, wall = [], []
    gc.disable()
    try:
        for _ in range(repeats):
            began_cpu, began_wall = time.process_time(), time.perf_counter()
            for step in range(steps):
                call(step)
            cpu.append((time.process_time() - began_cpu) / steps)
            wall.append((time.perf_counter() - began_wall) / steps)
    finally:
        gc.enable()
    return cpu, wall


def report(name: str, cpu: list, wall: list, count: int) -> None:
    median = statistics.median(cpu)
    print(
        f'  {name:<34} {median * 1e3:7.3f} ms/step CPU ({min(cpu) * 1e3:.3f}-'
        f'{max(cpu) * 1e3:.3f}), {statistics.median(wall) * 1e3:7.3f} wall; '
        f'{count / median / 1e6:6.2f} M glove-steps/s '
        f"[{median * TRIAL_RATE / count:.0%} of the trial's step]",
        flush=True,
    )


def bench_batch(model: GloveModel, count: int, steps: int, repeats: int) -> None:
    """Print every figure for a batch of ``count`` gloves."""
    limits = SafetyLimits()
    state = batch_state(model, count)
    feedback = Feedback.of_state(state, model)
    print(f'{count} gloves, {steps} steps x {repeats} repeats:')
    for name, make in modes(model, count).items():
        loop = CommandLoop(make(), SafetyLimiter(limits, count=count))
        cpu, wall = time_calls(
            lambda step, loop=loop: loop.command(step * DT, DT, feedback), steps, repeats
        )
        report(f'{name} + limiter', cpu, wall, count)
    cpu, wall = time_calls(lambda step: Feedback.of_state(state, model), steps, repeats)
    report('force estimate (feedback)', cpu, wall, count)
    for name, make in modes(model, count).items():
        if name not in ('sine', 'force'):
            continue
        controller = BuiltInMode(make(), limits, estimator=model)
        controller.reset(count)
        cpu, wall = time_calls(
            lambda step, controller=controller: controller.command(step * DT, DT, state),
            steps,
            repeats,
        )
        report(f'BuiltInMode {name}, with estimate', cpu, wall, count)
    zeros = np.zeros((count, 3))
    policy = PolicyController(lambda observations: zeros, GloveEnv(model))
    policy.reset(count)
    cpu, wall = time_calls(lambda step: policy.command(step * DT, DT, state), steps, repeats)
    report('PolicyController, free policy', cpu, wall, count)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split('\n')[0])
    parser.add_argument(
        '--count', type=int, nargs='+', default=[10_000, 1_000], help='gloves per batch'
    )
    parser.add_argument('--steps', type=int, default=50, help='calls timed per repeat')
    parser.add_argument('--repeats', type=int, default=5, help='timed loops per figure')
    options = parser.parse_args()
    model = GloveModel()
    for count in options.count:
        bench_batch(model, count, options.steps, options.repeats)


if __name__ == '__main__':
    main()
