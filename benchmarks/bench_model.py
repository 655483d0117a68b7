"""Speed of exodigit_model, printed as figures (issue 2): `make bench` or this script.

Measures, on this machine, in one run:
- warm-started coupled solve along a staircase (0 -> 50 kPa in 0.5 kPa steps, all chambers);
- cold solve from q = 0 at 50 kPa;
- tau_s for three joints (the solver's hot path, and the numpy API);
- batch forward solve of 10,000 random pressure triples (0-60 kPa);
- the same with every segment extensible (issue 10): warm solve and batch;
- the naive solve a researcher would write (scipy quad/dblquad for tau_s, finite-difference
  Jacobians of the kinematics, scipy.optimize.fsolve), the speed-up ratio and the agreement.
"""

from __future__ import annotations

import argparse
import gc
import math
import sys
import time
from pathlib import Path

import numpy as np
from scipy import integrate, optimize

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / 'tests'))
from model_reference import EVERY_TERM

from exodigit_model import (
    GloveModel,
    GloveSimulation,
    SimulationSettings,
    load_params,
    params_from_dict,
)


def _timed(function, *args, **kwargs):
    start = time.perf_counter()
    result = function(*args, **kwargs)
    return time.perf_counter() - start, result


def _percentiles(seconds):
    micro = np.asarray(seconds) * 1e6
    return np.median(micro), np.percentile(micro, 99)


class NaiveModel:
    """Eq 36 solved the straightforward way, independent of exodigit_model's internals."""

    def __init__(self, params):
        self.params = params
        self.segments = params.exo_digit.segments
        self.d = [params.exo_digit.base_block_half_length] + [
            s.block_half_length for s in self.segments
        ]
        self.links = [j.link_half_length for j in params.finger.joints]
        self.k = np.array([j.stiffness for j in params.finger.joints])
        self.b = np.array([self._pressure_moment(s) for s in self.segments])

    @staticmethod
    def _pressure_moment(s):
        r = s.inner_radius + s.wall_thickness
        h, b = s.wall_height, s.base_thickness
        return math.pi / 2 * r**2 * (4 * r / (3 * math.pi) + h + b) + 2 * r * (h / 2 + b) * h

    def _sigma(self, lam):
        c = self.params.material
        lt = lam**2 + lam**-2 - 2
        return 2 * (lam**2 - lam**-2) * (c.c1 + 2 * c.c2 * lt + 3 * c.c3 * lt**2)

    def _moment(self, s, qi):
        r0, t, h, b, ell = (
            s.inner_radius,
            s.wall_thickness,
            s.wall_height,
            s.base_thickness,
            s.arc_length,
        )

        def sigma_at(y):
            return self._sigma(1 + y * qi / ell)

        base = integrate.quad(lambda y: sigma_at(y) * 2 * (r0 + t) * y, 0, b)[0]
        wall = integrate.quad(lambda y: sigma_at(y) * 2 * t * y, b, b + h)[0]
        arch = integrate.dblquad(
            lambda phi, r: sigma_at(b + h + r * math.sin(phi)) * (b + h + r * math.sin(phi)) * r,
            r0,
            r0 + t,
            0,
            math.pi / 2,
        )[0]
        return base + wall + 2 * arch

    def tau_s(self, q):
        return -np.array([self._moment(s, qi) for s, qi in zip(self.segments, q, strict=True)])

    def robot_centres(self, q):
        x, y, phi, centres = 0.0, 0.0, 0.0, []
        for i in range(3):
            ell = self.segments[i].arc_length
            qi = q[i]
            ax = ell * math.sin(qi) / qi if qi != 0 else ell
            ay = ell * (1 - math.cos(qi)) / qi if qi != 0 else 0.0
            lx = 2 * self.d[i] + ax
            x += math.cos(phi) * lx - math.sin(phi) * ay
            y += math.sin(phi) * lx + math.cos(phi) * ay
            phi += qi
            centres.append((x + self.d[i + 1] * math.cos(phi), y + self.d[i + 1] * math.sin(phi)))
        return np.array(centres)

    def finger_centres(self, q):
        x, y, phi, centres = 0.0, 0.0, 0.0, []
        for i in range(3):
            phi += q[i]
            centres.append((x + self.links[i] * math.cos(phi), y + self.links[i] * math.sin(phi)))
            x += 2 * self.links[i] * math.cos(phi)
            y += 2 * self.links[i] * math.sin(phi)
        return np.array(centres)

    @staticmethod
    def jacobian(points, q, step=1e-7):
        phi = np.cumsum(q)
        normals = np.stack([-np.sin(phi), np.cos(phi)], axis=1)
        jac = np.zeros((3, 3))
        for k in range(3):
            dq = np.zeros(3)
            dq[k] = step
            diff = (points(q + dq) - points(q - dq)) / (2 * step)
            jac[:, k] = np.sum(normals * diff, axis=1)
        return jac

    def residual(self, q, p):
        j_r = self.jacobian(self.robot_centres, q)
        j_h = self.jacobian(self.finger_centres, q)
        force = np.linalg.solve(j_h.T, self.k * q)
        return self.tau_s(q) + self.b * p - j_r.T @ force

    def solve(self, p, q0):
        return optimize.fsolve(self.residual, q0, args=(p,), xtol=1e-13)


def _bench_extensible(staircase) -> None:
    """Issue 10: every segment extensible (MODEL.md §12), six unknowns per solve."""
    segments = [{'layer_axial_stiffness': e} for e in (0.0, 50.0, 20.0)]
    model = GloveModel(params_from_dict({'exo_digit': {'segments': segments}}))
    times, iterations = [], []
    for _ in range(10):
        previous = None
        for level in staircase:
            elapsed, previous = _timed(model.solve, np.full(3, level), previous)
            times.append(elapsed)
            iterations.append(previous.iterations)
    median, p99 = _percentiles(times)
    print(
        f'warm extensible coupled solve (E_L = 0, 50, 20 N), the same staircase: median '
        f'{median:.1f} us, p99 {p99:.1f} us, median iterations {np.median(iterations):g}'
        '  [median <= 150 us]'
    )
    rng = np.random.default_rng(3)
    pressures = rng.uniform(0.0, 60e3, (10_000, 3))
    model.solve_batch(pressures[:100])
    cold_time, cold = _timed(model.solve_batch, pressures)
    stepped = pressures + rng.uniform(-500.0, 500.0, pressures.shape)
    warm_time, warm = _timed(model.solve_batch, stepped, cold.q, lengths0=cold.lengths)
    print(
        f'extensible batch of 10,000 random triples: from rest {10_000 / cold_time:,.0f} '
        f'solves/s; the next 0.5 kPa step from those {10_000 / warm_time:,.0f} solves/s; all '
        f'converged: {bool(cold.converged.all() and warm.converged.all())}  [>= 100,000/s]'
    )


def bench(naive_steps: int) -> None:
    params = load_params()
    build_time, model = _timed(GloveModel, params)
    print(f'GloveModel construction (tabulating tau_s): {build_time * 1e3:.1f} ms')
    gc.disable()

    staircase = np.arange(0.0, 50e3 + 1, 500.0)
    times, iterations = [], []
    for _ in range(10):
        previous = None
        for level in staircase:
            start = None if previous is None else previous.q
            elapsed, previous = _timed(model.solve, np.full(3, level), start)
            times.append(elapsed)
            iterations.append(previous.iterations)
    warm_median, warm_p99 = _percentiles(times)
    print(
        f'warm coupled solve from the previous angles, 0.5 kPa staircase ({len(times)} solves): '
        f'median {warm_median:.1f} us, p99 {warm_p99:.1f} us, '
        f'median iterations {np.median(iterations):g}  [median <= 100 us, stretch 50 us]'
    )
    simulation = GloveSimulation(model, SimulationSettings(pressure_time_constant=0.0))
    steps = [_timed(simulation.step, np.full(3, level))[0] for level in np.tile(staircase, 10)]
    print(
        'the same staircase through GloveSimulation.step (reuses the last evaluation): median '
        f'{_percentiles(steps)[0]:.1f} us'
    )

    patient = GloveModel(params_from_dict({'finger': {'joints': [EVERY_TERM] * 3}}))
    effort = np.array([0.003, 0.002, 0.001])
    times, previous = [], np.full(3, 0.25)
    before = previous
    for _ in range(10):
        for level in staircase:
            # started where the last step's motion goes on, as GloveSimulation does
            start = previous + (previous - before)
            elapsed, solution = _timed(
                patient.solve,
                np.full(3, level),
                start,
                effort=effort,
                q_previous=previous,
                dt=0.01,
            )
            times.append(elapsed)
            before, previous = previous, solution.q
    print(
        'warm stepped solve with every patient term on (rest angle, range-of-motion stiffening, '
        f'damping, spasticity, effort): median {_percentiles(times)[0]:.1f} us, p99 '
        f'{_percentiles(times)[1]:.1f} us  [median <= 100 us]'
    )
    rng = np.random.default_rng(2)
    pressures = rng.uniform(0.0, 60e3, (10_000, 3))
    before = patient.solve_batch(pressures).q
    after = pressures + rng.uniform(-500.0, 500.0, pressures.shape)
    patient.solve_batch(
        after[:100], effort=np.tile(effort, (100, 1)), Q_previous=before[:100], dt=0.01
    )
    batch_time, batch = _timed(
        patient.solve_batch,
        after,
        effort=np.tile(effort, (10_000, 1)),
        Q_previous=before,
        dt=0.01,
    )
    print(
        f'batch of 10,000 stepped solves with every patient term on: {batch_time * 1e3:.0f} ms, '
        f'{10_000 / batch_time:,.0f} solves/s, all converged: {bool(batch.converged.all())}'
        '  [>= 200,000/s]'
    )

    _bench_extensible(staircase)

    cold = [_timed(model.solve, np.full(3, 50e3))[0] for _ in range(300)]
    print(f'cold solve from q = 0 at 50 kPa: median {_percentiles(cold)[0]:.1f} us  [<= 500 us]')

    angles = np.radians([30.0, 25.0, 15.0])
    q_list = angles.tolist()
    hot = []
    for _ in range(3000):
        start = time.perf_counter()
        for joint, angle in zip(model.structural.scalar_joints, q_list, strict=True):
            joint(angle)
        hot.append(time.perf_counter() - start)
    api = [_timed(model.structural_torque, angles)[0] for _ in range(3000)]
    print(
        f'tau_s, three joints: solver hot path {_percentiles(hot)[0]:.2f} us, '
        f'numpy API {_percentiles(api)[0]:.2f} us  [<= 10 us]'
    )

    pressures = np.random.default_rng(1).uniform(0.0, 60e3, (10_000, 3))
    model.solve_batch(pressures[:100])
    batch_time, batch = _timed(model.solve_batch, pressures)
    print(
        f'batch forward solve of 10,000 triples: {batch_time * 1e3:.0f} ms, '
        f'{10_000 / batch_time:,.0f} solves/s, all converged: {bool(batch.converged.all())}'
        '  [>= 20,000/s, stretch 100,000/s]'
    )
    gc.enable()

    naive = NaiveModel(params)
    levels = np.linspace(0.0, 50e3, naive_steps + 1)[1:]
    naive_times, ours_times, worst = [], [], 0.0
    q_naive, previous = np.zeros(3), None
    for level in levels:
        p = np.full(3, level)
        elapsed, q_naive = _timed(naive.solve, p, q_naive)
        naive_times.append(elapsed)
        elapsed, previous = _timed(model.solve, p, None if previous is None else previous.q)
        ours_times.append(elapsed)
        worst = max(worst, float(np.max(np.abs(q_naive - previous.q))))
    ratio = np.median(naive_times) / np.median(ours_times)
    print(
        f'naive solve (quad/dblquad tau_s, finite-difference Jacobians, fsolve), warm-started '
        f'over {naive_steps} pressure levels: median {np.median(naive_times) * 1e3:.0f} ms; '
        f'ours on the same steps {np.median(ours_times) * 1e6:.0f} us; speed-up {ratio:,.0f}x; '
        f'max |q difference| {worst:.2e} rad  [>= 1000x at <= 1e-9 rad]'
    )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument(
        '--naive-steps', type=int, default=5, help='pressure levels for the slow naive baseline'
    )
    bench(parser.parse_args().naive_steps)


if __name__ == '__main__':
    main()
