"""The valve mode over the box of issue 35: accuracy at every corner, and what it costs.

1. Speed, CPU time (``process_time``; the machine is a shared VM), each measured ``--repeats``
   times (median and range), ratios measured in the same run:
   a. a batch of 1,000 default gloves, ``GloveSimulation(model, count=1000).step``, on the
      workload of benchmarks/bench_sim.py figure 3c (a sine of pressures 0-40 kPa, its share of
      40 kPa as the inlets' opening, the rest as the outlets'), behind regulators and behind
      valves [valves >= 50 % of the regulators' glove-steps/s];
   b. the same batch behind valves with the air of each corner of the box
      (tests/valves_corners.py), on that workload and on fill-hold-vent pulses (every chamber
      filled 60 ms, held 20 ms, vented 60 ms, each glove its own phase: the transients where
      a step splits): the slowest corner's time per glove-step against the default air's
      [<= 3x].
2. Accuracy (``--errors``): at every corner on the default and the extensible glove, the
   largest pressure error against the reference of tests/valves_reference.py at 100 Hz (10 ms
   openings) and at 50, 100, 200 and 400 Hz (20 ms openings) [< 500 Pa at 50-200 Hz], with
   the observed orders. About ten minutes in all.

Run: ``.venv/bin/python benchmarks/bench_valves_corners.py [--repeats 3] [--errors]`` after
``make warm``.
"""

import argparse
import gc
import itertools
import statistics
import sys
import time
import warnings
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / 'tests'))

from valves_corners import CORNERS, GLOVES, model, pressure_error

from exodigit_model import GloveModel, GloveSimulation

GLOVES_IN_BATCH = 1000
RESOLVED = 2.0
"""Errors below this (Pa) give no order (tests/test_model_valves_corners.py)."""
SETTLE, TIMED = 20, 100
"""Steps before the clock starts, and timed steps, per repeat."""
SINE_PERIOD = 400
"""Steps of one period of the sine (bench_sim.py's)."""


def sine_workload(count: int) -> np.ndarray:
    """(SINE_PERIOD, count, 6) openings: each glove its own phase of bench_sim's sine."""
    k = np.arange(SINE_PERIOD)[:, None]
    phases = np.linspace(0.0, 2.0 * np.pi, count, endpoint=False)
    share = 0.5 * (1.0 - np.cos(2.0 * np.pi * k / SINE_PERIOD + phases))
    share = np.repeat(share[..., None], 3, axis=-1)
    return np.ascontiguousarray(np.concatenate([share, 1.0 - share], axis=-1))


def pulse_workload(count: int) -> np.ndarray:
    """(14, count, 6) openings: fill 6 steps, hold 2, vent 6; glove r shifted by r steps."""
    cycle = np.array([[1, 1, 1, 0, 0, 0]] * 6 + [[0] * 6] * 2 + [[0, 0, 0, 1, 1, 1]] * 6, float)
    shifts = np.arange(count) % len(cycle)
    rows = [cycle[(t + shifts) % len(cycle)] for t in range(len(cycle))]
    return np.ascontiguousarray(np.array(rows))


def regulator_workload(count: int) -> np.ndarray:
    k = np.arange(SINE_PERIOD)[:, None]
    phases = np.linspace(0.0, 2.0 * np.pi, count, endpoint=False)
    pressure = 20e3 * (1.0 - np.cos(2.0 * np.pi * k / SINE_PERIOD + phases))
    return np.ascontiguousarray(np.repeat(pressure[..., None], 3, axis=-1))


def seconds_per_glove_step(glove_model, actuation, workload, repeats) -> list[float]:
    """CPU s per glove-step of the batch on ``workload`` (rows cycled), ``repeats`` times."""
    count = workload.shape[1]
    gloves = GloveSimulation(glove_model, count=count, actuation=actuation)
    k = 0
    for _ in range(SETTLE):
        gloves.step(workload[k % len(workload)])
        k += 1
    timings = []
    for _ in range(repeats):
        rows = [workload[(k + i) % len(workload)] for i in range(TIMED)]
        k += TIMED
        gc.disable()
        try:
            start = time.process_time()
            for row in rows:
                gloves.step(row)
            timings.append((time.process_time() - start) / (TIMED * count))
        finally:
            gc.enable()
    return timings


def shown(timings: list[float]) -> str:
    rates = sorted(1.0 / t for t in timings)
    return f'{statistics.median(rates):,.0f} glove-steps/s ({rates[0]:,.0f}-{rates[-1]:,.0f})'


def speed(repeats: int) -> None:
    default = GloveModel()
    sine = sine_workload(GLOVES_IN_BATCH)
    pulses = pulse_workload(GLOVES_IN_BATCH)
    regulator = seconds_per_glove_step(
        default, 'regulator', regulator_workload(GLOVES_IN_BATCH), repeats
    )
    valves = seconds_per_glove_step(default, 'valves', sine, repeats)
    share = statistics.median(regulator) / statistics.median(valves)
    print(f'1a. regulators: {shown(regulator)}; valves: {shown(valves)}')
    print(f'1a. the valve batch at {100 * share:.0f} % of the regulator batch  [>= 50 %]')
    for name, workload in (('sine', sine), ('fill-hold-vent pulses', pulses)):
        base = statistics.median(seconds_per_glove_step(default, 'valves', workload, repeats))
        worst, slowest = 0.0, None
        with warnings.catch_warnings():
            warnings.simplefilter('ignore')
            for corner in CORNERS:
                cost = statistics.median(
                    seconds_per_glove_step(model('default', corner), 'valves', workload, repeats)
                )
                if cost > worst:
                    worst, slowest = cost, corner
        print(
            f'1b. {name}: default air {1 / base:,.0f} glove-steps/s; slowest corner {slowest} '
            f'{1 / worst:,.0f}: {worst / base:.2f}x the default  [<= 3x]'
        )


def accuracy() -> None:
    rates = (50.0, 100.0, 200.0, 400.0)
    worst = dict.fromkeys(rates, 0.0)
    lowest = (float('inf'), None)
    for glove in GLOVES:
        for corner in CORNERS:
            fine = pressure_error(glove, corner, 100.0, fine=True)
            errors = [pressure_error(glove, corner, rate) for rate in rates]
            orders = [np.log2(a / b) for a, b in itertools.pairwise(errors)]
            for rate, error in zip(rates, errors, strict=True):
                worst[rate] = max(worst[rate], error)
            if errors[2] > RESOLVED:
                lowest = min(lowest, (np.log2(errors[0] / errors[2]) / 2, (glove, corner)))
            print(
                f'2. {glove} {corner}: 10 ms openings {fine:.1f} Pa at 100 Hz; 20 ms openings '
                + ' / '.join(f'{e:.1f}' for e in errors)
                + ' Pa at 50/100/200/400 Hz, orders '
                + ', '.join(f'{o:.2f}' for o in orders),
                flush=True,
            )
    print(
        '2. largest error over every corner and glove: '
        + ', '.join(f'{worst[rate]:.1f} Pa at {rate:.0f} Hz' for rate in rates)
        + '  [< 500 Pa at 50-200 Hz]'
    )
    print(f'2. lowest mean order from 50 to 200 Hz: {lowest[0]:.2f} {lowest[1]}')


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split('\n\n')[0])
    parser.add_argument('--repeats', type=int, default=3, help='timings per figure (3)')
    parser.add_argument('--errors', action='store_true', help='also figure 2 (long)')
    parser.add_argument('--no-speed', action='store_true', help='skip figure 1')
    args = parser.parse_args()
    if not args.no_speed:
        speed(args.repeats)
    if args.errors:
        accuracy()


if __name__ == '__main__':
    main()
