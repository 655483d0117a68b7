"""Speed of exodigit_model's compiled kernels, printed as figures ("The model at compiled speed").

Run ``python -m exodigit_model.tools.warm`` first (``make bench`` does), so that no kernel
compiles inside a figure; then ``.venv/bin/python benchmarks/bench_model.py`` (``--help``: the
options). Every line ends with its target in brackets. Figures:

- GloveModel construction (tabulating tau_s), the first in the process and the next ones;
- warm coupled solve along a staircase (0 -> 50 kPa in 0.5 kPa steps, all chambers, each solve
  started from the previous angles);
- the same staircase stepped in time with every patient term on (rest angle, range-of-motion
  stiffening, damping, spasticity, effort), started where the last step's motion goes on;
- the same staircase with every segment extensible (issue 10): six unknowns per solve;
- cold solve from q = 0 at 50 kPa; ``estimate_forces`` at the staircase's states; tau_s of three
  joints (``GloveModel.structural_torque``);
- batches of 10,000 random pressure triples: forward, stepped with every patient term on,
  extensible from rest and the next 0.5 kPa step from there;
- the naive solve a researcher would write (scipy quad/dblquad for tau_s, finite-difference
  Jacobians of the kinematics, scipy.optimize.fsolve): the speed-up and the agreement.

``GloveSimulation`` (one glove's ``step`` and ``run``, a batch of 1,000 gloves) is measured in
``benchmarks/bench_sim.py``, figure 3.

How it measures (a shared 2-core VM: other processes run beside it)
-------------------------------------------------------------------
Each workload is a fixed list of calls, recorded once by making them (a warm start is the
previous call's result, so replaying the list makes the same calls without the loop's own
arithmetic). One call runs untimed first (it loads the cached kernels). Then, ``--repeats``
times: the list once with every call timed by ``perf_counter`` (wall time; the median and the
99th percentile per call, which include about one clock read), and once as a bare loop between
``process_time`` and ``perf_counter`` reads (CPU and wall time per call). Ranges are over the
repeats; the figure is their median. The garbage collector is off while timing.

Ratios (``Nx``) compare CPU time per call with the plain-Python path of the same source
(``EXODIGIT_JIT=0``), measured in the same run: the script runs itself with ``--plain`` in a
subprocess, which records and replays the same workloads as bare loops (``--plain-repeats``
times; the batches with 1,000 rows instead of 10,000) and prints its timings as JSON.
"""

from __future__ import annotations

import argparse
import gc
import json
import math
import os
import sys
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from scipy import integrate, optimize

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / 'tests'))
from exodigit_model.kernels import jit
from model_reference import EVERY_TERM
from plain_path import run_plain

from exodigit_model import GloveModel, load_params, params_from_dict

STAIRCASE = np.arange(0.0, 50e3 + 1, 500.0)
"""The staircase's pressure levels, Pa (0 -> 50 kPa in 0.5 kPa steps)."""
SWEEPS = 10
"""Times each staircase is climbed per pass (from the bottom each time)."""
BATCH_ROWS = 10_000
PLAIN_BATCH_ROWS = 1_000
"""Rows of the batch figures, compiled and in the plain-Python subprocess."""
EFFORT = np.array([0.003, 0.002, 0.001])
"""The patient's voluntary effort in the stepped figures, N·m."""
DT = 0.01
"""Time step of the stepped figures, s."""


# -- measuring -----------------------------------------------------------------------------


@dataclass
class Workload:
    """A fixed list of calls of ``function``, each ``rows`` operations (rows of a batch)."""

    function: Callable
    calls: list[tuple[tuple, dict]]
    rows: int = 1


@dataclass
class Timing:
    """A workload's times over repeats, s: per operation (bare loop) and per call (timed)."""

    cpu: list[float] = field(default_factory=list)
    wall: list[float] = field(default_factory=list)
    median: list[float] = field(default_factory=list)
    p99: list[float] = field(default_factory=list)
    first: float = 0.0
    """Wall time of the untimed first call (loads, or compiles, the kernels), s."""


def _replay(function: Callable, calls: list[tuple[tuple, dict]]) -> list:
    return [function(*args, **kwargs) for args, kwargs in calls]


def _timed_replay(function: Callable, calls: list[tuple[tuple, dict]]) -> list[float]:
    clock, times = time.perf_counter, []
    for args, kwargs in calls:
        start = clock()
        function(*args, **kwargs)
        times.append(clock() - start)
    return times


def measure(workload: Workload, repeats: int, per_call: bool) -> Timing:
    """Time ``workload`` ``repeats`` times (module docstring); ``per_call``: also call by call."""
    timing = Timing()
    args, kwargs = workload.calls[0]
    start = time.perf_counter()
    workload.function(*args, **kwargs)
    timing.first = time.perf_counter() - start
    operations = len(workload.calls) * workload.rows
    gc.disable()
    try:
        for _ in range(repeats):
            if per_call:
                times = _timed_replay(workload.function, workload.calls)
                timing.median.append(float(np.median(times)))
                timing.p99.append(float(np.percentile(times, 99)))
            cpu, wall = time.process_time(), time.perf_counter()
            _replay(workload.function, workload.calls)
            timing.cpu.append((time.process_time() - cpu) / operations)
            timing.wall.append((time.perf_counter() - wall) / operations)
    finally:
        gc.enable()
    return timing


def _span(values: list[float], scale: float, digits: int) -> str:
    """'lo-hi' of ``values`` × ``scale``."""
    low, high = min(values) * scale, max(values) * scale
    return f'{low:,.{digits}f}-{high:,.{digits}f}'


def per_call_text(timing: Timing, digits: int = 1) -> str:
    """Per-call medians, p99 and CPU per call of a timing, in us."""
    median = float(np.median(timing.median)) * 1e6
    p99 = float(np.median(timing.p99)) * 1e6
    cpu = float(np.median(timing.cpu)) * 1e6
    wall = float(np.median(timing.wall)) * 1e6
    return (
        f'median {median:.{digits}f} us per call ({_span(timing.median, 1e6, digits)} over '
        f'{len(timing.median)} repeats), p99 {p99:.{digits}f} us; bare loop {cpu:.{digits}f} '
        f'us CPU ({_span(timing.cpu, 1e6, digits)}), {wall:.{digits}f} us wall'
    )


def rate_text(timing: Timing, unit: str) -> str:
    """Operations per second of a timing, CPU (range over repeats) and wall."""
    cpu = 1.0 / float(np.median(timing.cpu))
    wall = 1.0 / float(np.median(timing.wall))
    rates = [1.0 / value for value in timing.cpu]
    return (
        f'{cpu:,.0f} {unit}/s CPU ({_span(rates, 1.0, 0)} over {len(rates)} repeats), '
        f'{wall:,.0f}/s wall'
    )


def ratio_text(timing: Timing, plain: dict | None, unit: str = 'us', scale: float = 1e6) -> str:
    """'; plain Python X unit CPU: Nx' (CPU per operation, plain over compiled), or ''."""
    if plain is None:
        return ''
    plain_cpu = float(np.median(plain['cpu']))
    ratio = plain_cpu / float(np.median(timing.cpu))
    return f'; plain Python {plain_cpu * scale:,.1f} {unit} CPU: {ratio:,.1f}x'


def plain_rate_text(timing: Timing, plain: dict | None, unit: str) -> str:
    """'; plain Python X unit/s CPU: Nx', or ''."""
    if plain is None:
        return ''
    plain_cpu = float(np.median(plain['cpu']))
    ratio = plain_cpu / float(np.median(timing.cpu))
    rows = plain['rows']
    return f'; plain Python {1.0 / plain_cpu:,.0f} {unit}/s CPU ({rows:,} rows): {ratio:,.1f}x'


# -- the workloads -------------------------------------------------------------------------


def staircase_calls(model: GloveModel, *, solution_start: bool = False) -> list:
    """The warm staircase, ``SWEEPS`` times: each solve started from the previous one.

    ``solution_start``: pass the previous Solution itself (its angles and lengths), as an
    extensible glove needs; else its angles.
    """
    calls = []
    for _ in range(SWEEPS):
        previous = None
        for level in STAIRCASE:
            start = previous if solution_start or previous is None else previous.q
            args = (np.full(3, level), start)
            previous = model.solve(*args)
            calls.append((args, {}))
    return calls


def stepped_calls(patient: GloveModel) -> list:
    """The staircase stepped in time, started where the last step's motion goes on."""
    calls = []
    before = previous = np.full(3, 0.25)
    for _ in range(SWEEPS):
        for level in STAIRCASE:
            # started where the last step's motion goes on, as GloveSimulation does
            args = (np.full(3, level), previous + (previous - before))
            kwargs = {'effort': EFFORT, 'q_previous': previous, 'dt': DT}
            solution = patient.solve(*args, **kwargs)
            calls.append((args, kwargs))
            before, previous = previous, solution.q
    return calls


def workloads(params, batch_rows: int) -> dict[str, Workload]:
    """Every figure's workload, recorded by making its calls once (the plain path's too)."""
    model = GloveModel(params)
    patient = GloveModel(params_from_dict({'finger': {'joints': [EVERY_TERM] * 3}}))
    segments = [{'layer_axial_stiffness': e} for e in (0.0, 50.0, 20.0)]
    extensible = GloveModel(params_from_dict({'exo_digit': {'segments': segments}}))
    warm = staircase_calls(model)
    states = [(model.solve(*args).q, args[0]) for args, _ in warm[: len(STAIRCASE)]]
    angles = np.radians([30.0, 25.0, 15.0])

    rng = np.random.default_rng(1)
    forward = rng.uniform(0.0, 60e3, (batch_rows, 3))
    rng = np.random.default_rng(2)
    pressures = rng.uniform(0.0, 60e3, (batch_rows, 3))
    before = patient.solve_batch(pressures).q
    after = pressures + rng.uniform(-500.0, 500.0, pressures.shape)
    stepped_batch = {'effort': np.tile(EFFORT, (batch_rows, 1)), 'Q_previous': before, 'dt': DT}
    rng = np.random.default_rng(3)
    pressures = rng.uniform(0.0, 60e3, (batch_rows, 3))
    rest = extensible.solve_batch(pressures)
    stepped = pressures + rng.uniform(-500.0, 500.0, pressures.shape)
    return {
        'construction': Workload(GloveModel, [((params,), {})] * 5),
        'warm': Workload(model.solve, warm),
        'stepped': Workload(patient.solve, stepped_calls(patient)),
        'extensible': Workload(extensible.solve, staircase_calls(extensible, solution_start=True)),
        'cold': Workload(model.solve, [((np.full(3, 50e3),), {})] * 300),
        'estimate': Workload(model.estimate_forces, [(state, {}) for state in states] * 20),
        'tau_s': Workload(model.structural_torque, [((angles,), {})] * 3000),
        'batch': Workload(model.solve_batch, [((forward,), {})], batch_rows),
        'patient_batch': Workload(patient.solve_batch, [((after,), stepped_batch)], batch_rows),
        'extensible_rest': Workload(extensible.solve_batch, [((pressures,), {})], batch_rows),
        'extensible_step': Workload(
            extensible.solve_batch,
            [((stepped, rest.q), {'lengths0': rest.lengths})],
            batch_rows,
        ),
    }


def outcome(workload: Workload) -> str:
    """Median Newton iterations of a solve workload's calls, and whether all converged."""
    results = _replay(workload.function, workload.calls)
    iterations = np.concatenate([np.atleast_1d(r.iterations) for r in results])
    converged = all(np.all(r.converged) for r in results)
    return f'median iterations {np.median(iterations):g}, all converged: {converged}'


# -- the naive baseline ----------------------------------------------------------------------


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
        """fsolve from ``q0``: the angles, and whether fsolve reports convergence."""
        q, _, status, _ = optimize.fsolve(
            self.residual, q0, args=(p,), xtol=1e-13, full_output=True
        )
        return q, status == 1


def naive_figure(params, model: GloveModel, steps: int, repeats: int) -> None:
    """The naive solve against ours, warm-started over the same ``steps`` pressure levels."""
    naive = NaiveModel(params)
    levels = [np.full(3, level) for level in np.linspace(0.0, 50e3, steps + 1)[1:]]
    naive_q, fsolve_converged, q = [], 0, np.zeros(3)
    cpu, wall = time.process_time(), time.perf_counter()
    for p in levels:
        q, converged = naive.solve(p, q)
        naive_q.append(q)
        fsolve_converged += converged
    naive_cpu = (time.process_time() - cpu) / steps
    naive_wall = (time.perf_counter() - wall) / steps
    naive_residual = max(
        float(np.max(np.abs(naive.residual(q, p)))) for q, p in zip(naive_q, levels, strict=True)
    )

    calls, previous = [], None
    for p in levels:
        args = (p, None if previous is None else previous.q)
        previous = model.solve(*args)
        calls.append((args, {}))
    ours = _replay(model.solve, calls)
    worst = max(float(np.max(np.abs(a - b.q))) for a, b in zip(naive_q, ours, strict=True))
    converged = all(solution.converged for solution in ours)
    timing = measure(Workload(model.solve, calls * 200), repeats, per_call=False)
    ours_cpu = float(np.median(timing.cpu))
    print(
        f'naive solve (quad/dblquad tau_s, finite-difference Jacobians, fsolve), warm-started '
        f'over {steps} pressure levels to 50 kPa: {naive_cpu * 1e3:,.0f} ms CPU per solve '
        f'({naive_wall * 1e3:,.0f} ms wall; fsolve reported success {fsolve_converged}/{steps}, '
        f'max |residual| {naive_residual:.1e} N m); ours '
        f'on the same steps {ours_cpu * 1e6:.1f} us CPU ({_span(timing.cpu, 1e6, 1)} over '
        f'{repeats} repeats of 200 sweeps; all converged: {converged}); speed-up '
        f'{naive_cpu / ours_cpu:,.0f}x CPU, {naive_wall / float(np.median(timing.wall)):,.0f}x '
        f'wall; max |q difference| {worst:.2e} rad  [>= 10,000x at <= 1e-9 rad]'
    )


# -- the two paths -------------------------------------------------------------------------


def plain_timings(repeats: int) -> dict:
    """Bare-loop timings of every workload on this process's path (the ``--plain`` mode)."""
    start = time.perf_counter()
    params = load_params()
    timings = {}
    for name, workload in workloads(params, PLAIN_BATCH_ROWS).items():
        timing = measure(workload, repeats, per_call=False)
        timings[name] = {'cpu': timing.cpu, 'wall': timing.wall, 'rows': workload.rows}
    return {'jit': jit.JIT, 'seconds': time.perf_counter() - start, 'timings': timings}


def _clock_read(clock: Callable[[], float]) -> float:
    """Seconds one read of ``clock`` takes."""
    start = time.perf_counter()
    for _ in range(10_000):
        clock()
    return (time.perf_counter() - start) / 10_000


def header() -> None:
    """What was measured: the path, the kernel source, the machine."""
    if jit.JIT:
        import numba

        path = f'compiled (numba {numba.__version__}, cache {jit.cache_directory()})'
    else:
        path = 'NOT compiled (numba missing or EXODIGIT_JIT=0): every figure is plain Python'
    load = ' '.join(f'{value:.2f}' for value in os.getloadavg())
    print(
        f'exodigit_model kernels {path}, source digest {jit.source_digest()}; '
        f'{os.cpu_count()} cores, load average {load}; one clock read: perf_counter '
        f'{_clock_read(time.perf_counter) * 1e6:.2f} us, process_time '
        f'{_clock_read(time.process_time) * 1e6:.2f} us'
    )


def bench(repeats: int, plain_repeats: int, naive_steps: int) -> None:
    began = time.perf_counter()
    header()
    plain = run_plain(__file__, plain_repeats) if plain_repeats > 0 else None
    if plain is not None:
        print(
            f'plain-Python path (EXODIGIT_JIT=0, a subprocess, {plain_repeats} repeats, '
            f'batches of {PLAIN_BATCH_ROWS:,} rows): {plain["seconds"]:.0f} s'
        )

    def plain_of(name: str) -> dict | None:
        return None if plain is None else plain['timings'][name]

    params = load_params()
    first = time.perf_counter()
    GloveModel(params)
    first = time.perf_counter() - first
    jobs = workloads(params, BATCH_ROWS)
    timings = {
        name: measure(workload, repeats, per_call=workload.rows == 1 and name != 'construction')
        for name, workload in jobs.items()
    }

    t = timings['construction']
    print(
        f'GloveModel construction (tabulating tau_s): the first in this process '
        f'{first * 1e3:.0f} ms wall (it loads the compiled kernels), the next '
        f'{float(np.median(t.cpu)) * 1e3:.1f} ms CPU ({_span(t.cpu, 1e3, 1)} over {repeats} '
        f'repeats of 5), {float(np.median(t.wall)) * 1e3:.1f} ms wall'
        f'{ratio_text(t, plain_of("construction"), "ms", 1e3)}  [no target]'
    )
    steps = f'{len(STAIRCASE) * SWEEPS:,} solves'
    print(
        f'warm coupled solve from the previous angles, 0.5 kPa staircase to 50 kPa ({steps}): '
        f'{per_call_text(timings["warm"])}{ratio_text(timings["warm"], plain_of("warm"))}; '
        f'{outcome(jobs["warm"])}  [median <= 5 us, >= 20x plain Python]'
    )
    print(
        'warm stepped solve with every patient term on (rest angle, range-of-motion stiffening, '
        f'damping, spasticity, effort), the same staircase at dt = {DT:g} s ({steps}): '
        f'{per_call_text(timings["stepped"])}{ratio_text(timings["stepped"], plain_of("stepped"))}'
        f'; {outcome(jobs["stepped"])}  [median <= 8 us]'
    )
    print(
        f'warm extensible coupled solve (E_L = 0, 50, 20 N), the same staircase ({steps}): '
        f'{per_call_text(timings["extensible"])}'
        f'{ratio_text(timings["extensible"], plain_of("extensible"))}; '
        f'{outcome(jobs["extensible"])}  [median <= 20 us]'
    )
    print(
        f'cold solve from q = 0 at 50 kPa (300 solves): {per_call_text(timings["cold"])}'
        f'{ratio_text(timings["cold"], plain_of("cold"))}; {outcome(jobs["cold"])}'
        '  [median <= 20 us]'
    )
    print(
        "estimate_forces at the staircase's solved states (2,020 calls): "
        f'{per_call_text(timings["estimate"], 2)}'
        f'{ratio_text(timings["estimate"], plain_of("estimate"))}  [median <= 5 us]'
    )
    print(
        'tau_s of three joints, GloveModel.structural_torque (3,000 calls): '
        f'{per_call_text(timings["tau_s"], 2)}{ratio_text(timings["tau_s"], plain_of("tau_s"))}'
        '  [median <= 10 us]'
    )
    rows = f'{BATCH_ROWS:,}'
    for name, text, target in (
        ('batch', f'batch forward solve of {rows} random triples (0-60 kPa)', '>= 20,000/s'),
        (
            'patient_batch',
            f'batch of {rows} stepped solves with every patient term on (each row +-0.5 kPa '
            'from its static solution, dt = 0.01 s)',
            '>= 200,000/s',
        ),
        (
            'extensible_rest',
            f'extensible batch of {rows} random triples from rest',
            '>= 100,000/s',
        ),
        (
            'extensible_step',
            f'extensible batch of {rows}: the next 0.5 kPa step from those',
            '>= 100,000/s',
        ),
    ):
        timing = timings[name]
        print(
            f'{text}: {rate_text(timing, "solves")}'
            f'{plain_rate_text(timing, plain_of(name), "solves")}; {outcome(jobs[name])}'
            f'  [{target}]'
        )

    naive_figure(params, GloveModel(params), naive_steps, repeats)
    slow = [f'{name} {t.first:.0f} s' for name, t in timings.items() if t.first > 1.0]
    if slow:
        print(
            f'note: first calls that took over 1 s: {", ".join(slow)} (kernels compiled during '
            'the run, untimed; `python -m exodigit_model.tools.warm` does not cover them, or '
            'was not run first)  [none]'
        )
    print(f'bench_model.py: {time.perf_counter() - began:.0f} s in all  [no target]')


def main() -> None:
    parser = argparse.ArgumentParser(
        description=__doc__.splitlines()[0],
        epilog='Run `python -m exodigit_model.tools.warm` first. The module docstring says '
        'how each figure is measured.',
    )
    parser.add_argument(
        '--repeats',
        type=int,
        default=5,
        help='times each figure is measured; the figure is the median, the range is printed '
        '(default 5)',
    )
    parser.add_argument(
        '--plain-repeats',
        type=int,
        default=2,
        help='times each figure is measured on the plain-Python path (EXODIGIT_JIT=0, in a '
        'subprocess) for the "Nx" ratios; 0: skip that path and print no ratios (default 2)',
    )
    parser.add_argument(
        '--naive-steps',
        type=int,
        default=5,
        help='pressure levels (0 -> 50 kPa) the slow naive scipy baseline solves (default 5)',
    )
    parser.add_argument(
        '--plain',
        action='store_true',
        help="internal: time every workload as bare loops on this process's path (--repeats "
        'times, small batches) and print the timings as one JSON line; what the script runs in '
        'its EXODIGIT_JIT=0 subprocess',
    )
    args = parser.parse_args()
    if args.repeats < 1 or args.plain_repeats < 0 or args.naive_steps < 1:
        parser.error('--repeats and --naive-steps must be >= 1, --plain-repeats >= 0')
    if args.plain:
        print(json.dumps(plain_timings(args.repeats)))
    else:
        bench(args.repeats, args.plain_repeats, args.naive_steps)


if __name__ == '__main__':
    main()
