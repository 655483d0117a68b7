"""How often ``exodigit calibrate-air``'s 95 % intervals cover the truth, over many seeds.

The glove of tests/test_tools_calibrate_air.py (its TRUTH: valves, dead volumes and leaks
unlike the defaults, a 150 kPa supply) records the documented excitation (docs/calibrate_air.md)
with 300 Pa of pressure noise, a new noise seed per fit, and ``fit_air`` fits it back from the
defaults. Printed per seed: the fit's time (CPU), status, how many of the 18 quantities it
identified and how many intervals cover the truth, the largest normalised error
|θ̂ − θ|/σ; then the coverage over all seeds with its binomial standard error, per quantity,
and the mean and spread of the normalised errors [coverage near 0.95; z mean near 0, standard
deviation near 1].

Run: ``.venv/bin/python benchmarks/bench_calibrate_air.py [--seeds 20] [--rate 100]`` after
``make warm``; about 15 s of CPU per seed at 100 Hz.
"""

import argparse
import math
import statistics
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / 'tests'))

from exodigit_model.tools.air_calibration import fit_air, values_of
from exodigit_model.tools.air_recording import excitation, simulated_recording
from test_tools_calibrate_air import NOISE, START, TRUTH, z_scores


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split('\n\n')[0])
    parser.add_argument('--seeds', type=int, default=20, help='fits, one noise seed each (20)')
    parser.add_argument('--first-seed', type=int, default=1000, help='the first seed (1000)')
    parser.add_argument('--rate', type=float, default=100.0, help='recording rate, Hz (100)')
    args = parser.parse_args()
    openings = excitation(args.rate)
    inside, scores, times = [], [], []
    for seed in range(args.first_seed, args.first_seed + args.seeds):
        recording = simulated_recording(
            TRUTH, openings, args.rate, pressure_noise=NOISE, seed=seed
        )
        began = time.process_time()
        fit = fit_air(START, recording)
        times.append(time.process_time() - began)
        truth = values_of(TRUTH, fit.parameters)
        covered = (fit.lower <= truth) & (truth <= fit.upper)
        z = z_scores(fit, truth)
        inside.append(covered)
        scores.append(z)
        print(
            f'seed {seed}: {times[-1]:.1f} s, status {fit.status}, '
            f'{int(fit.identified.sum())} of 18 identified, {int(covered.sum())} of 18 '
            f'intervals cover the truth, largest |z| {np.abs(z).max():.2f}',
            flush=True,
        )
    inside = np.array(inside)
    rate = inside.mean()
    spread = math.sqrt(0.95 * 0.05 / inside.size)
    print(
        f'coverage {rate:.3f} of {inside.size} intervals over {args.seeds} seeds '
        f'(0.95 ± {spread:.3f} expected)  [near 0.95]'
    )
    for k, parameter in enumerate(fit.parameters):
        print(f'  {parameter.key:28s} {inside[:, k].mean():.2f}')
    z = np.concatenate(scores)
    print(f'z: mean {z.mean():+.2f}, standard deviation {z.std():.2f}  [0, 1]')
    shown = f'{statistics.median(times):.1f} s ({min(times):.1f}-{max(times):.1f})'
    print(f'CPU per fit: median {shown}')


if __name__ == '__main__':
    main()
