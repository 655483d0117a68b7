"""Cases that both kernel paths run: the compiled one and plain Python (``EXODIGIT_JIT=0``).

tests/test_model_kernels.py computes :func:`compute` in its own process (compiled kernels) and
runs this file as a script in a subprocess with ``EXODIGIT_JIT=0``, which writes the same cases
computed by plain Python with :func:`save`; the test then compares them array by array. Each
case drives the public API (:class:`exodigit_model.GloveModel`, :class:`GloveSimulation`) and
returns a list of numpy arrays; together the cases reach every kernel behind that API.

Usage: ``python tests/kernel_cases.py OUTPUT.npz``.
"""

from __future__ import annotations

import functools
import sys
import warnings
from collections.abc import Callable

import numpy as np
from exodigit_model.kernels import jit
from exodigit_model.kernels.valves import AIR_VOLUME, advance_masses
from exodigit_model.physics.pneumatics import air_constants, flow_function, mass_flow, rest_masses
from exodigit_model.physics.validity import OutsideModelWarning

from exodigit_model import (
    GloveModel,
    GloveSimulation,
    GloveState,
    SimulationSettings,
    load_params,
    params_from_dict,
    patient_file,
)

#: A patient joint with every term of docs/spec/model.md (11.1)-(11.3) on, within default ranges.
EVERY_TERM = {
    'stiffness': 0.12,
    'rest_angle': 0.3,
    'rom_torque': 0.01,
    'rom_sharpness': 12.0,
    'damping': 0.004,
    'spasticity': 0.03,
    'extensor_spasticity': 0.01,
    'spasticity_threshold': 0.4,
}
#: Bottom-layer stiffness per segment, N (None: inextensible): all extensible, and a mix.
EXTENSIBLE_STIFFNESS = (0.0, 50.0, 20.0)
MIXED_STIFFNESS = (0.0, None, 80.0)

#: Chamber pressures (Pa), rows of them, and a second point for warm starts.
PRESSURE = np.array([40e3, 55e3, 30e3])
OTHER_PRESSURE = np.array([60e3, 35e3, 45e3])
PRESSURES = np.linspace([5e3, 0.0, 10e3], [70e3, 60e3, 50e3], 5)
#: Angles (rad), their rows, speeds (rad/s, both signs beyond the spastic threshold), efforts
#: (N·m) and the angles one step earlier (rad) of the stepped solves, whose step is DT (s).
ANGLES = np.array([0.5, 0.7, 0.4])
ANGLE_ROWS = np.linspace([0.1, 0.2, 0.05], [0.9, 1.1, 0.8], 5)
SPEED = np.array([1.5, -1.2, 0.6])
EFFORT = np.array([0.01, -0.02, 0.005])
DT = 0.01
PREVIOUS = ANGLES - DT * SPEED
#: Angles (rad) for τ_s: inside the table, at zero, and beyond both of its ends (top-fibre
#: strain above U_MAX = 1.6 and below U_MIN = -0.6: the quadrature fallback answers).
STRUCTURAL_ANGLES = np.array(
    [[0.3, 0.6, 0.9], [0.0, 0.0, 0.0], [7.0, 5.0, 2.5], [-2.5, -1.7, -0.8]]
)
#: Simulated steps, and the settings of the simulated gloves: chamber lag, both sensors noisy.
STEPS = 200
BATCH_STEPS = 30
BATCH = 5
NOISY = SimulationSettings(angle_noise_std=1e-3, pressure_noise_std=200.0, seed=11)


def commands(steps: int = STEPS) -> np.ndarray:
    """Pressure commands (steps, 3), Pa: sines from −15 to 125 kPa (both ends saturate)."""
    t = np.arange(steps)[:, None] * 0.01
    return 55e3 + 70e3 * np.sin(2.0 * np.pi * 1.5 * t + np.array([0.0, 1.0, 2.0]))


def openings(steps: int = STEPS) -> np.ndarray:
    """Valve openings (steps, 6): u_in then u_out of MCP, PIP, DIP, from −0.2 to 1.2 (both
    ends clipped), filling and venting in turn."""
    t = np.arange(steps)[:, None] * 0.01
    inlet = 0.5 + 0.7 * np.sin(2.0 * np.pi * 1.5 * t + np.array([0.0, 1.0, 2.0]))
    return np.concatenate([inlet, 1.0 - inlet], axis=1)


def efforts(steps: int = STEPS) -> np.ndarray:
    """Voluntary efforts (steps, 3), N·m."""
    t = np.arange(steps)[:, None] * 0.01
    return 0.02 * np.cos(2.0 * np.pi * 0.7 * t + np.array([0.5, 0.0, -0.5]))


def glove(stiffness=None, joints=None, material=None) -> GloveModel:
    """The default glove with ``layer_axial_stiffness`` per segment, patient ``joints``."""
    data = {}
    if stiffness is not None:
        data['exo_digit'] = {
            'segments': [{} if e is None else {'layer_axial_stiffness': e} for e in stiffness]
        }
    if joints is not None:
        data['finger'] = {'joints': [dict(joints) for _ in range(3)]}
    if material is not None:
        data['material'] = material
    return GloveModel(params_from_dict(data))


@functools.cache
def models() -> dict[str, GloveModel]:
    """The gloves of the cases, built once per process."""
    return {
        'default': GloveModel(),
        'stroke': GloveModel(load_params(patient_file('stroke_moderate'))),
        'patient': glove(joints=EVERY_TERM),
        'extensible': glove(EXTENSIBLE_STIFFNESS),
        'mixed': glove(MIXED_STIFFNESS),
        'extensible patient': glove(EXTENSIBLE_STIFFNESS, joints=EVERY_TERM),
        # A silicone of C1 = 1 Pa holds 5 kPa on the finger but not 100 kPa.
        'soft': glove(material={'c1': 1.0, 'c2': 0.0, 'c3': 0.0}),
    }


SOLUTION_FIELDS = (
    'q',
    'forces',
    'finger_torque',
    'pressure',
    'lengths',
    'residual',
    'status',
    'iterations',
    'in_valid_range',
    'in_range_of_motion',
)
"""The fields of a Solution or a BatchSolution that :func:`solution` returns, in order."""


def solution(result) -> list[np.ndarray]:
    """Every field of a Solution or a BatchSolution, as arrays (integers kept integers)."""
    return [np.asarray(getattr(result, field)) for field in SOLUTION_FIELDS]


def states(simulation: GloveSimulation, history) -> list[np.ndarray]:
    """Every field of a GloveState (a step's, or stacked steps'), and the simulation's counts.

    A field that is None (the air of a glove with regulators) gives an empty array.
    """
    counts = [
        simulation.chambers.saturation.below_zero,
        simulation.chambers.saturation.above_supply,
        simulation.solver_failures,
        simulation.step_count,
    ]
    fields = [np.empty(0) if field is None else np.asarray(field) for field in history]
    return [*fields, np.array(counts)]


def stacked(steps) -> GloveState:
    """A list of GloveStates as one state whose fields have a leading axis of steps.

    A field that is None in every step (the air of a glove with regulators) stays None.
    """
    return GloveState(
        *(None if values[0] is None else np.array(values) for values in zip(*steps, strict=True))
    )


CASES: dict[str, Callable[[], list[np.ndarray]]] = {}
"""The cases by name: each a call of no arguments that returns a list of arrays."""


def case(function: Callable[[], list[np.ndarray]]) -> Callable[[], list[np.ndarray]]:
    """Register ``function`` in :data:`CASES` under its name."""
    CASES[function.__name__] = function
    return function


@case
def torque_tables() -> list[np.ndarray]:
    # Built when a model is made, by the section quadrature kernel.
    return [model.constants.table for model in models().values()]


@case
def solve_cold_and_warm() -> list[np.ndarray]:
    default, stroke = models()['default'], models()['stroke']
    cold = default.solve(PRESSURE)
    warm = default.solve(OTHER_PRESSURE, cold.q)
    return solution(cold) + solution(warm) + solution(stroke.solve(PRESSURE))


@case
def solve_stepped_patient() -> list[np.ndarray]:
    stroke, patient = models()['stroke'], models()['patient']
    results = [
        stroke.solve(PRESSURE, effort=EFFORT, q_previous=PREVIOUS, dt=DT),
        patient.solve(PRESSURE, effort=EFFORT, q_previous=PREVIOUS, dt=DT),
        patient.solve(OTHER_PRESSURE, ANGLES, effort=-EFFORT, q_previous=PREVIOUS, dt=DT),
        patient.solve(PRESSURE, effort=EFFORT),
    ]
    return [array for result in results for array in solution(result)]


@case
def solve_free() -> list[np.ndarray]:
    default, extensible = models()['default'], models()['extensible']
    return [
        *solution(default.solve(PRESSURE, free=True)),
        default.solve_free(OTHER_PRESSURE),
        extensible.solve_free(PRESSURE),
    ]


@case
def solve_extensible() -> list[np.ndarray]:
    extensible, mixed = models()['extensible'], models()['mixed']
    moving = models()['extensible patient']
    cold = extensible.solve(PRESSURE)
    results = [
        cold,
        extensible.solve(OTHER_PRESSURE, cold),  # warm: from the angles and lengths
        mixed.solve(PRESSURE),
        moving.solve(PRESSURE, effort=EFFORT, q_previous=PREVIOUS, dt=DT),
    ]
    return [array for result in results for array in solution(result)]


@case
def solve_batch() -> list[np.ndarray]:
    default, patient = models()['default'], models()['patient']
    extensible, mixed = models()['extensible'], models()['mixed']
    rest = extensible.constants.arc_lengths
    previous = ANGLE_ROWS - DT * SPEED
    results = [
        default.solve_batch(PRESSURES),
        default.solve_batch(PRESSURES, free=True),
        patient.solve_batch(
            PRESSURES, ANGLE_ROWS, effort=np.tile(EFFORT, (5, 1)), Q_previous=previous, dt=DT
        ),
        extensible.solve_batch(PRESSURES, ANGLE_ROWS, lengths0=np.tile(rest * 1.02, (5, 1))),
        mixed.solve_batch(PRESSURES),
    ]
    return [array for result in results for array in solution(result)]


def held(result) -> list[np.ndarray]:
    """The arrays of a ``hold`` result (and its status as an array)."""
    return [result.pressure, result.lengths, np.array(result.status)]


def estimated(result) -> list[np.ndarray]:
    """The arrays of an ``estimate`` result (and its status as an array)."""
    return [result.forces, result.lengths, np.array(result.status)]


@case
def pressure_for_and_hold() -> list[np.ndarray]:
    named = models()
    return [
        named['default'].pressure_for(ANGLES),
        *held(named['default'].hold(ANGLES)),
        *held(named['patient'].hold(ANGLES, SPEED, EFFORT)),
        named['stroke'].pressure_for(ANGLES, -SPEED, EFFORT),
        *held(named['extensible'].hold(ANGLES)),
        *held(named['extensible patient'].hold(ANGLES, SPEED, EFFORT)),
        named['mixed'].pressure_for(ANGLES, SPEED),
    ]


@case
def estimate() -> list[np.ndarray]:
    named = models()
    return [
        named['default'].estimate_forces(ANGLES, PRESSURE),
        *estimated(named['default'].estimate(ANGLES, PRESSURE)),
        *estimated(named['extensible'].estimate(ANGLES, PRESSURE)),
        named['extensible'].estimate_forces(ANGLES, OTHER_PRESSURE),
        *estimated(named['mixed'].estimate(ANGLES, PRESSURE)),
    ]


@case
def estimate_batch_and_fit() -> list[np.ndarray]:
    named = models()
    arrays = [
        named['default'].estimate_forces_batch(ANGLE_ROWS, PRESSURES),
        named['extensible'].estimate_forces_batch(ANGLE_ROWS, PRESSURES),
        named['stroke'].estimate_finger_torque(ANGLE_ROWS, PRESSURES),
    ]
    for name in ('stroke', 'extensible'):
        fit = named[name].fit_stiffness(ANGLE_ROWS, PRESSURES)
        arrays += [
            fit.stiffness,
            fit.standard_error,
            fit.rest_angle,
            fit.rest_angle_standard_error,
            fit.rmse,
            np.asarray(fit.samples),
        ]
    return arrays


@case
def residual_and_jacobian() -> list[np.ndarray]:
    named = models()
    lengths = named['extensible'].constants.arc_lengths * np.array([1.03, 1.01, 1.05])
    calls = [
        (named['default'], {}),
        (named['default'], {'free': True}),
        (named['patient'], {'effort': EFFORT, 'q_previous': PREVIOUS, 'dt': DT}),
        (named['extensible'], {'lengths': lengths}),
        (named['extensible patient'], {'effort': EFFORT, 'q_previous': PREVIOUS, 'dt': DT}),
        (named['mixed'], {'lengths': lengths}),
    ]
    return [
        array
        for model, options in calls
        for array in (
            model.residual(ANGLES, PRESSURE, **options),
            model.residual_jacobian(ANGLES, PRESSURE, **options),
        )
    ]


@case
def jacobians() -> list[np.ndarray]:
    default = models()['default']
    return [
        *default.contact_jacobians(ANGLES),
        *default.contact_jacobians(-ANGLES),
        default.length_jacobian(ANGLES),
        default.length_jacobian(ANGLES, default.constants.arc_lengths * 1.04),
    ]


@case
def structural() -> list[np.ndarray]:
    default = models()['default']
    return [
        default.structural_torque(STRUCTURAL_ANGLES),
        default.structural_stiffness(STRUCTURAL_ANGLES),
        default.structural_torque(STRUCTURAL_ANGLES[2]),
    ]


@case
def finger_and_geometry() -> list[np.ndarray]:
    named = models()
    patient, stroke = named['patient'], named['stroke']
    forces = patient.finger_forces(ANGLES, SPEED, EFFORT)
    pose = stroke.pose(ANGLES, stroke.constants.arc_lengths * 1.02)
    return [
        patient.finger_torque(ANGLES, SPEED, EFFORT),
        patient.finger_torque(ANGLES, -SPEED),
        forces,
        patient.contact_torque(ANGLES, forces),
        stroke.in_valid_range(STRUCTURAL_ANGLES),
        stroke.in_range_of_motion(ANGLE_ROWS - 0.3),
        named['extensible'].in_valid_range(ANGLES, 0.6),
        *(np.asarray(field) for field in vars(pose).values()),
    ]


@case
def simulation_step() -> list[np.ndarray]:
    simulation = GloveSimulation(models()['stroke'], NOISY)
    history = [simulation.step(c, e) for c, e in zip(commands(), efforts(), strict=True)]
    return states(simulation, stacked(history)) + states(simulation, simulation.state)


@case
def simulation_run() -> list[np.ndarray]:
    simulation = GloveSimulation(models()['stroke'], NOISY)
    history = simulation.run(commands(), efforts())
    return states(simulation, history) + states(simulation, simulation.state)


@case
def simulation_batch() -> list[np.ndarray]:
    simulation = GloveSimulation(models()['extensible patient'], NOISY, count=BATCH)
    scales = np.linspace(0.3, 1.1, BATCH)[:, None]
    history = [
        simulation.step(scales * c, scales * e)
        for c, e in zip(commands(BATCH_STEPS), efforts(BATCH_STEPS), strict=True)
    ]
    return states(simulation, stacked(history))


@case
def simulation_population() -> list[np.ndarray]:
    # Extensible segments on three patients: nominal, stroke_moderate, every term of eq 11.1.
    named = models()
    fingers = [named[name].params.finger for name in ('default', 'stroke', 'patient')]
    simulation = GloveSimulation(named['extensible'], NOISY, fingers=fingers)
    rest = states(simulation, simulation.state)
    scales = np.array([0.3, 0.7, 1.1])[:, None]
    history = [
        simulation.step(scales * c, scales * e)
        for c, e in zip(commands(BATCH_STEPS), efforts(BATCH_STEPS), strict=True)
    ]
    return rest + states(simulation, stacked(history)) + states(simulation, simulation.reset())


@case
def valves_step_and_run() -> list[np.ndarray]:
    stepped = GloveSimulation(models()['stroke'], NOISY, actuation='valves')
    history = [stepped.step(u, e) for u, e in zip(openings(), efforts(), strict=True)]
    ran = GloveSimulation(models()['extensible patient'], NOISY, actuation='valves')
    record = ran.run(openings(), efforts())
    return (
        states(stepped, stacked(history))
        + states(ran, record)
        + states(ran, ran.reset())
        + states(ran, ran.step(openings()[1]))
    )


@case
def valves_population() -> list[np.ndarray]:
    named = models()
    fingers = [named[name].params.finger for name in ('default', 'stroke', 'patient')]
    simulation = GloveSimulation(named['extensible'], NOISY, fingers=fingers, actuation='valves')
    scales = np.array([0.3, 0.7, 1.1])[:, None]
    history = [
        simulation.step(scales * u, scales * e)
        for u, e in zip(openings(BATCH_STEPS), efforts(BATCH_STEPS), strict=True)
    ]
    return states(simulation, stacked(history)) + states(simulation, simulation.reset())


@case
def air() -> list[np.ndarray]:
    rows = air_constants(models()['default'], 150e3)
    masses = rest_masses(rows[:, AIR_VOLUME], 293.15)
    start = rows[:, AIR_VOLUME].copy()  # contiguous, as the simulation's: no second compile
    end = start * 1.1
    return [
        advance_masses(rows, masses, start, end, np.array([1.0, 0.5, 0.2, 0.0, 0.3, 0.0]), DT),
        advance_masses(
            rows, 3.0 * masses, end, start, np.array([0.0, 0.2, 0.0, 1.0, 0.7, 0.4]), DT
        ),
        np.array([flow_function(r, 0.3) for r in (0.1, 0.3, 0.5, 0.999, 0.9995, 1.0)]),
        np.array([mass_flow(5e-10, 0.3, p, 2e5, 300.0) for p in (1e5, 1.9999e5, 2e5, 5e5)]),
    ]


@case
def failures() -> list[np.ndarray]:
    named = models()
    default, soft = named['default'], named['soft']
    results = [
        default.solve(np.full(3, -1e9)),  # the line search finds no decrease
        soft.solve(np.full(3, 100e3)),  # likewise, after many iterations
        soft.solve_batch(np.array([[5e3, 5e3, 5e3], [100e3, 100e3, 100e3]])),
    ]
    with warnings.catch_warnings():
        # Plain Python: numpy scalars warn of the overflow; compiled code does not.
        warnings.simplefilter('ignore', RuntimeWarning)
        results.append(default.solve(np.full(3, 1e300)))  # a residual that is not finite
    simulation = GloveSimulation(soft, SimulationSettings(pressure_time_constant=0.0))
    history = [simulation.step(np.full(3, p)) for p in (5e3, 100e3, 5e3)]
    arrays = [array for result in results for array in solution(result)]
    return arrays + states(simulation, stacked(history))


def compute() -> dict[str, list[np.ndarray]]:
    """Every case of :data:`CASES`, computed by this process's kernels.

    Some cases leave the validated model on purpose (a pressure beyond the supply, a stretch
    beyond the validated range): they compare the two paths, not the model's validity, so
    their `OutsideModelWarning` is expected here, whichever test computes them first.
    """
    with warnings.catch_warnings():
        warnings.simplefilter('ignore', OutsideModelWarning)
        return {name: run() for name, run in CASES.items()}


def save(path: str) -> None:
    """Write :func:`compute` and :data:`jit.JIT` to ``path`` (``np.savez``)."""
    arrays = {
        f'{name}.{index}': array
        for name, results in compute().items()
        for index, array in enumerate(results)
    }
    np.savez(path, jit=np.array(jit.JIT), **arrays)


def load(path: str) -> tuple[bool, dict[str, list[np.ndarray]]]:
    """What :func:`save` wrote: (whether that process compiled, the cases)."""
    cases: dict[str, list[tuple[int, np.ndarray]]] = {}
    with np.load(path) as archive:
        compiled = bool(archive['jit'])
        for key in archive.files:
            if key != 'jit':
                name, index = key.rsplit('.', 1)
                cases.setdefault(name, []).append((int(index), archive[key]))
    return compiled, {name: [array for _, array in sorted(items)] for name, items in cases.items()}


if __name__ == '__main__':
    # As in the test suite (pytest.ini): the model's RuntimeWarnings are errors.
    warnings.filterwarnings('error', category=RuntimeWarning, module='exodigit_model')
    save(sys.argv[1])
