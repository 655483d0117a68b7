"""Compile every kernel into the cache: ``python -m exodigit_model.tools.warm``.

Each case drives the public API the way the nodes, runners and tests do, with the argument
types they pass, so numba compiles (and caches, :mod:`.jit`) every signature they will need; a
later process only loads. One line per case says how long it took: a cold cache compiles, a
warm one only loads. Then the caches of older kernel sources are removed (:func:`.jit.prune`).

Add a case to :data:`JOBS` for every public entry point that reaches a kernel with new
argument types. Without JIT (numba missing or ``EXODIGIT_JIT=0``) there is nothing to compile:
the command says so and does nothing.
"""

from __future__ import annotations

import logging
import multiprocessing
import os
import sys
import time
from collections.abc import Callable
from concurrent.futures import ProcessPoolExecutor

import numpy as np

from exodigit_model.physics.material import yeoh_stress
from exodigit_model.physics.pneumatics import ATMOSPHERIC_PRESSURE, flow_function, mass_flow

from .. import compiling
from ..kernels import jit
from ..kernels.patient import finger_torque
from ..kernels.section import resultants
from ..physics.model import GloveModel
from ..physics.params import load_params, params_from_dict, patient_file
from ..stepping.simulation import GloveSimulation

#: Chamber pressures (Pa) of the cases: a point, and rows of a batch.
PRESSURE = np.array([40e3, 55e3, 30e3])
PRESSURES = np.linspace([0.0, 0.0, 0.0], [60e3, 50e3, 40e3], 8)
#: Voluntary effort (N·m) and time step (s) of the stepped solves.
EFFORT = np.array([0.01, 0.0, -0.01])
DT = 0.01
#: Steps of a simulation's run.
STEPS = 5
#: Valve openings (u_in, then u_out, of MCP, PIP, DIP) of the cases behind valves.
OPENINGS = np.array([1.0, 0.5, 0.2, 0.0, 0.1, 0.0])


def _models() -> dict[str, GloveModel]:
    """The gloves the cases exercise: default, extensible segments and a patient preset."""
    segments = [{'layer_axial_stiffness': stiffness} for stiffness in (0.0, 50.0, 20.0)]
    return {
        'default glove': GloveModel(),
        'extensible glove': GloveModel(params_from_dict({'exo_digit': {'segments': segments}})),
        'stroke_moderate patient': GloveModel(load_params(patient_file('stroke_moderate'))),
    }


def exercise_model(model: GloveModel) -> None:
    """Every solve, inverse and estimator of a :class:`~exodigit_model.GloveModel`."""
    q = model.solve(PRESSURE).q
    model.solve(PRESSURE, q)
    model.solve(PRESSURE, free=True)
    model.solve(PRESSURE, q_previous=q, dt=DT, effort=EFFORT)
    rows = model.solve_batch(PRESSURES).q
    model.solve_batch(PRESSURES, Q_previous=rows, dt=DT)
    model.pressure_for(q)
    model.hold(q)
    model.estimate_forces(q, PRESSURE)
    model.estimate_forces_batch(rows, PRESSURES)
    model.fit_stiffness(rows, PRESSURES)


def exercise_geometry(model: GloveModel) -> None:
    """Torques, Jacobians, residuals, poses and the validity checks of the model."""
    q = model.solve(PRESSURE).q
    rows = model.solve_batch(PRESSURES).q
    model.finger_torque(q, q, EFFORT)
    model.finger_forces(q)
    model.contact_jacobians(q)
    model.robot_contact_torque(q, EFFORT)
    model.robot_contact_torque(rows, np.ones_like(rows))
    model.length_jacobian(q)
    model.residual(q, PRESSURE)
    model.residual_jacobian(q, PRESSURE, q_previous=q, dt=DT)
    model.structural_torque(q)
    model.structural_torque(rows)
    model.estimate_finger_torque(q, PRESSURE)
    model.pose(q)
    model.in_valid_range(rows)
    model.in_range_of_motion(q)
    # the numpy API of the material and the kernels a researcher (or a test) calls directly
    yeoh_stress(model.params.material, np.linspace(0.9, 1.5, 7))
    resultants(model.constants, 0, float(q[0]), 0.01)
    finger_torque(model.constants.laws[0], float(q[0]), 0.1, 100.0)


def exercise_simulation(model: GloveModel) -> None:
    """Steps and runs of one glove, of four, and of a population of two patients.

    (:class:`~exodigit_model.GloveSimulation`; the population's fingers: the model's own and
    the ``stroke_moderate`` preset's.)
    """
    one = GloveSimulation(model)
    one.step(PRESSURE)
    one.step(PRESSURE, EFFORT)
    one.run(np.tile(PRESSURE, (STEPS, 1)))
    one.run(np.tile(PRESSURE, (STEPS, 1)), np.tile(EFFORT, (STEPS, 1)))
    batch = GloveSimulation(model, count=4)
    batch.step(np.tile(PRESSURE, (4, 1)))
    batch.step(np.tile(PRESSURE, (4, 1)), np.tile(EFFORT, (4, 1)))
    batch.run(np.tile(PRESSURE, (STEPS, 4, 1)))
    batch.run(np.tile(PRESSURE, (STEPS, 4, 1)), np.tile(EFFORT, (STEPS, 4, 1)))
    fingers = [model.params.finger, load_params(patient_file('stroke_moderate')).finger]
    population = GloveSimulation(model, fingers=fingers)
    population.step(np.tile(PRESSURE, (2, 1)), np.tile(EFFORT, (2, 1)))
    population.reset()


def exercise_valves(model: GloveModel) -> None:
    """The simulations of :func:`exercise_simulation` behind valves, and the air's functions."""
    one = GloveSimulation(model, actuation='valves')
    one.step(OPENINGS)
    one.step(OPENINGS, EFFORT)
    one.run(np.tile(OPENINGS, (STEPS, 1)))
    one.run(np.tile(OPENINGS, (STEPS, 1)), np.tile(EFFORT, (STEPS, 1)))
    batch = GloveSimulation(model, count=4, actuation='valves')
    batch.step(np.tile(OPENINGS, (4, 1)), np.tile(EFFORT, (4, 1)))
    batch.run(np.tile(OPENINGS, (STEPS, 4, 1)))
    batch.reset()
    flow_function(0.5, 0.3)
    mass_flow(5e-10, 0.3, 2 * ATMOSPHERIC_PRESSURE, ATMOSPHERIC_PRESSURE, 293.15)


Case = tuple[str, Callable[[GloveModel], object]]
"""A case of the warm-up: (name, function run on every model of :func:`_models`)."""

JOBS: tuple[tuple[Case, ...], ...] = (
    (('model', exercise_model), ('geometry', exercise_geometry)),
    (('simulation', exercise_simulation), ('valves', exercise_valves)),
)
"""The cases, by process: each job runs its cases in order, the jobs run side by side (one
process each, as many at once as this process may use CPUs). A case that reuses what another
compiled shares its job (geometry solves first, valves steps the simulation's kernels): two
processes that need one kernel at once both compile it. Cold, on an idle 2-core VM: 40 s and
35 s side by side, 41 s in all, against 66 s one job after the other."""


def run_job(job: tuple[Case, ...]) -> None:
    """Run the cases of ``job`` on every model, in order; print how long each took."""
    # The warm-up says what it compiles, case by case: not the notice that points to itself.
    logging.getLogger(compiling.__name__).setLevel(logging.ERROR)
    for model_name, model in _models().items():
        for name, exercise in job:
            began = time.perf_counter()
            exercise(model)
            label = f'{model_name}: {name}'
            print(f'  {label:<36} {time.perf_counter() - began:7.2f} s', flush=True)


def usable_cpus() -> int:
    """How many CPUs this process may run on."""
    return len(os.sched_getaffinity(0)) if hasattr(os, 'sched_getaffinity') else os.cpu_count()


def main() -> int:
    """Run every job, print each case's time, prune stale caches; the exit status (always 0).

    A case that fails raises here, whichever process ran it.
    """
    if not jit.JIT:
        print('exodigit_model kernels: no JIT (numba missing or EXODIGIT_JIT=0), nothing to warm')
        return 0
    directory = jit.cache_directory()
    workers = min(len(JOBS), usable_cpus() or 1)
    print(
        f'exodigit_model kernels: cache {directory or "none (compiled in memory)"}; '
        f'{len(JOBS)} jobs, {workers} at a time'
    )
    start = time.perf_counter()
    if workers == 1 or directory is None:  # in memory, only this process would gain
        for job in JOBS:
            run_job(job)
    else:
        spawn = multiprocessing.get_context('spawn')  # a fresh interpreter: no state shared
        with ProcessPoolExecutor(max_workers=workers, mp_context=spawn) as pool:
            for done in [pool.submit(run_job, job) for job in JOBS]:
                done.result()
    for path in jit.prune():
        print(f'  removed the stale cache {path}')
    print(f'  total {time.perf_counter() - start:.2f} s')
    return 0


if __name__ == '__main__':
    sys.exit(main())
