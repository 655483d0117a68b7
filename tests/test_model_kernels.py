"""The model's kernels: compiled against plain Python, run() against step(), a batch per glove.

1. The cases of tests/kernel_cases.py (every public entry point with a kernel behind it) run
   here with the compiled kernels and, once for the whole module, in a subprocess with
   ``EXODIGIT_JIT=0`` (plain Python): the two must give the same arrays.
2. ``GloveSimulation.run`` must give what as many calls of ``step`` give, bit for bit.
3. A batch of gloves must give, row by row, what single gloves give, bit for bit.
   2 and 3 also behind valves (docs/spec/model.md §14).
4. ``run`` must refuse bad input with a ValueError naming the argument, before any step.
"""

import os
import subprocess
import sys

import kernel_cases
import numpy as np
import pytest
from exodigit_model.kernels import jit
from exodigit_model.kernels.inverse import robot_contact_torques
from exodigit_model.kernels.stepping import step_gloves
from exodigit_model.physics.solver import CONVERGED_STEP, NOT_FINITE
from exodigit_model.physics.structural import PIECE_WIDTH, PIECES, U_MIN
from exodigit_model.stepping.settings import VENT
from kernel_cases import (
    EFFORT,
    NOISY,
    STRUCTURAL_ANGLES,
    commands,
    efforts,
    models,
    openings,
    stacked,
)

from exodigit_model import GloveModel, GloveSimulation, GloveState, SimulationSettings

#: Wall-clock limit of the plain-Python subprocess, s: a guard against a hang, not a timing
#: check (measured: 4 to 6 s on two shared cores; the compiled cases take about 2 s, cached).
PLAIN_TIMEOUT = 300
#: Fields of a GloveState that carry sensor noise.
MEASURED = ('pressure_measured', 'q_measured')
#: Settings without noise (a batch draws its noise for all gloves from one stream, so only
#: noise-free gloves can equal single ones), with chamber lag.
QUIET = SimulationSettings(seed=11)
#: Gloves of the run/step and batch/single comparisons (tests/kernel_cases.py): two patients
#: whose torque depends on speed (stroke: the preset; patient: every term of eq 11.1), an
#: extensible glove, both at once, and a soft glove whose solves fail at high pressure.
GLOVES = ('stroke', 'patient', 'extensible', 'extensible patient', 'soft')
#: GloveState fields that a batch has once for all its gloves.
SHARED = ('step', 't', 'time_ns', 'saturated')


def assert_identical(expected, actual, what: str) -> None:
    """``actual`` equals ``expected`` bit for bit: dtype, shape and every byte."""
    expected, actual = np.asarray(expected), np.asarray(actual)
    assert actual.dtype == expected.dtype, f'{what}: dtype {actual.dtype} != {expected.dtype}'
    np.testing.assert_array_equal(actual, expected, err_msg=what, strict=True)
    # Also tells -0.0 from 0.0 and NaN payloads apart, which assert_array_equal does not.
    assert actual.tobytes() == expected.tobytes(), what


def assert_same_states(expected, actual, what: str, skip=()) -> None:
    """Two GloveStates (or stacked ones) equal field by field, bit for bit, but ``skip``."""
    for field in expected._fields:
        if field not in skip:
            assert_identical(getattr(expected, field), getattr(actual, field), f'{what}.{field}')


def counts(simulation: GloveSimulation) -> tuple:
    """What a simulation counts: saturated steps per side, failed solves, steps."""
    saturation = simulation.chambers.saturation
    return (
        saturation.below_zero,
        saturation.above_supply,
        simulation.solver_failures,
        simulation.step_count,
    )


# -- 1. both paths agree --------------------------------------------------------------------


@pytest.fixture(scope='module')
def plain(tmp_path_factory):
    """(JIT flag, cases) computed by plain Python in one subprocess for the whole module."""
    path = tmp_path_factory.mktemp('plain') / 'cases.npz'
    result = subprocess.run(
        [sys.executable, kernel_cases.__file__, str(path)],
        env={**os.environ, 'EXODIGIT_JIT': '0'},
        capture_output=True,
        text=True,
        timeout=PLAIN_TIMEOUT,
    )
    assert result.returncode == 0, result.stderr
    return kernel_cases.load(str(path))


@pytest.fixture(scope='module')
def compiled():
    """The cases computed in this process, by the compiled kernels."""
    return kernel_cases.compute()


# Measured (numba 0.68.1, numpy 2.4.6, x86-64): all 408 arrays of the 17 cases (31 788 values)
# were bit-for-bit identical on both paths, floats and integers alike, so exact equality is
# asserted everywhere; no output needed the 1e-12 relative bound the compiled path was to be
# held to (the kernels call the math module, not numpy's vectorised functions, and compile
# without fastmath, so both paths round the same operations the same way; compiled with
# fastmath, the τ_s tables alone already differed in 1277 of 1320 coefficients).
@pytest.mark.parametrize('name', list(kernel_cases.CASES))
def test_the_compiled_kernels_give_bit_for_bit_what_plain_python_gives(name, plain, compiled):
    assert jit.JIT is True  # a silently disabled JIT would compare plain Python with itself
    plain_jit, plain_cases = plain
    assert plain_jit is False  # the subprocess ran the plain path
    expected, actual = plain_cases[name], compiled[name]
    assert len(actual) == len(expected)
    for index, (want, got) in enumerate(zip(expected, actual, strict=True)):
        assert_identical(want, got, f'{name}[{index}]')


def test_the_cases_reach_what_they_claim(compiled):
    """The cases cover the table's fallback, failed solves, saturation and noise."""
    strain = STRUCTURAL_ANGLES * models()['default'].constants.strain_per_angle
    table_end = U_MIN + PIECES * PIECE_WIDTH  # the τ_s table's top-fibre strains: [U_MIN, this]
    assert np.all(strain[2] > table_end) and np.all(strain[3] < U_MIN)  # the quadrature answers
    size = len(kernel_cases.SOLUTION_FIELDS)
    status = kernel_cases.SOLUTION_FIELDS.index('status')
    failures = compiled['failures']
    statuses = [failures[k * size + status] for k in range(4)]
    assert statuses[0] > CONVERGED_STEP and statuses[1] > CONVERGED_STEP
    assert statuses[2][0] <= CONVERGED_STEP < statuses[2][1]
    assert statuses[3] == NOT_FINITE
    assert failures[-1][2] == 1  # the soft glove's simulation kept its state once
    fields = len(GloveState._fields)
    below, above, _, steps = compiled['simulation_step'][fields]
    assert below > 0 and above > 0 and steps == kernel_cases.STEPS
    history = GloveState(*compiled['simulation_step'][:fields])
    assert not np.array_equal(history.q_measured, history.q)
    assert not np.array_equal(history.pressure_measured, history.pressure)


# -- 2. run() is many step() calls ----------------------------------------------------------


def run_and_steps(name: str, settings: SimulationSettings, with_efforts: bool = True):
    """Twin simulations of glove ``name``: one runs the commands, the other steps them.

    Both take a first step alone, so that run() starts from a moving glove (the speed-based
    warm start) at a step count above zero.
    """
    model = models()[name]
    ran, stepped = GloveSimulation(model, settings), GloveSimulation(model, settings)
    rows = commands()
    pushes = efforts() if with_efforts else [None] * len(rows)
    for simulation in (ran, stepped):
        simulation.step(rows[0], pushes[0])
    record = ran.run(rows[1:], efforts()[1:] if with_efforts else None)
    history = stacked([stepped.step(c, e) for c, e in zip(rows[1:], pushes[1:], strict=True)])
    return ran, stepped, record, history


@pytest.mark.parametrize('name', GLOVES)
def test_run_gives_what_as_many_steps_give(name):
    ran, stepped, record, history = run_and_steps(name, NOISY)
    assert_same_states(history, record, 'run', skip=MEASURED)
    assert counts(ran) == counts(stepped)
    assert_same_states(stepped.state, ran.state, 'state', skip=MEASURED)
    for attribute in ('pressure', 'command'):
        assert_identical(
            getattr(stepped.chambers, attribute),
            getattr(ran.chambers, attribute),
            f'chambers.{attribute}',
        )
    assert ran.chambers.saturated_now == stepped.chambers.saturated_now
    # The state run() leaves behind (the angles one step back too) goes on as the steps' does.
    after = [simulation.step(commands()[-1], EFFORT) for simulation in (stepped, ran)]
    assert_same_states(after[0], after[1], 'next step', skip=MEASURED)
    below, above, failed, _ = counts(ran)
    assert below > 0 and above > 0  # the commands saturate at both ends
    assert (failed > 0) == (name == 'soft')  # only the soft glove fails, and it does


def test_run_without_efforts_gives_what_as_many_steps_give():
    ran, stepped, record, history = run_and_steps('extensible patient', QUIET, False)
    assert_same_states(history, record, 'run')
    assert_same_states(stepped.state, ran.state, 'state')
    assert counts(ran) == counts(stepped)


def test_run_draws_each_steps_sensor_noise_as_step_does():
    ran, stepped, record, history = run_and_steps('stroke', NOISY)
    for field in MEASURED:
        assert_identical(getattr(history, field), getattr(record, field), f'run.{field}')
    assert_same_states(stepped.state, ran.state, 'state')
    after = [simulation.step(commands()[-1]) for simulation in (stepped, ran)]
    assert_same_states(after[0], after[1], 'next step')


def test_run_of_a_batch_gives_what_as_many_steps_give():
    model, count = models()['stroke'], 3
    scales = np.array([0.4, 0.8, 1.1])[:, None]
    rows = scales * commands()[:, None, :]
    pushes = scales * efforts()[:, None, :]
    ran = GloveSimulation(model, NOISY, count=count)
    stepped = GloveSimulation(model, NOISY, count=count)
    record = ran.run(rows, pushes)
    history = stacked([stepped.step(c, e) for c, e in zip(rows, pushes, strict=True)])
    assert record.q.shape == (len(rows), count, 3)
    assert_same_states(history, record, 'run')
    assert_same_states(stepped.state, ran.state, 'state')
    assert counts(ran) == counts(stepped)


# -- 3. a batch is its gloves ---------------------------------------------------------------


@pytest.mark.parametrize('name', GLOVES)
def test_each_glove_of_a_batch_steps_as_a_single_glove(name):
    model, count, steps = models()[name], 4, 60
    scales = np.linspace(0.05, 1.1, count)[:, None]
    batch = GloveSimulation(model, QUIET, count=count)
    singles = [GloveSimulation(model, QUIET) for _ in range(count)]
    below = above = 0
    for command, effort in zip(commands(steps), efforts(steps), strict=True):
        rows, pushes = scales * command, scales * effort
        state = batch.step(rows, pushes)
        alone = [single.step(rows[r], pushes[r]) for r, single in enumerate(singles)]
        for r, expected in enumerate(alone):
            per_glove = glove_of(state, r)
            assert_same_states(expected, per_glove, f'glove {r}', skip=('saturated',))
        assert state.saturated == any(expected.saturated for expected in alone)
        below += bool(np.any(rows < 0.0))
        above += bool(np.any(rows > QUIET.max_supply_pressure))
    saturation = batch.chambers.saturation
    assert (saturation.below_zero, saturation.above_supply) == (below, above)
    assert batch.solver_failures == sum(single.solver_failures for single in singles)
    assert below > 0 and above > 0
    assert (batch.solver_failures > 0) == (name == 'soft')


def glove_of(state: GloveState, r: int) -> GloveState:
    """Glove ``r``'s row of a batch's state (the fields the batch has once, and None, as
    they are)."""
    rows = {
        field: getattr(state, field)[r]
        for field in state._fields
        if field not in SHARED and getattr(state, field) is not None
    }
    return state._replace(**rows)


@pytest.mark.parametrize('name', ('stroke', 'extensible patient'))
def test_run_behind_valves_gives_what_as_many_steps_give(name):
    model, rows, pushes = models()[name], openings(), efforts()
    ran = GloveSimulation(model, NOISY, actuation='valves')
    stepped = GloveSimulation(model, NOISY, actuation='valves')
    for simulation in (ran, stepped):
        simulation.step(rows[0], pushes[0])
    record = ran.run(rows[1:], pushes[1:])
    history = stacked([stepped.step(u, e) for u, e in zip(rows[1:], pushes[1:], strict=True)])
    assert record.mass.shape == (len(rows) - 1, 3) and record.command.shape[1:] == (6,)
    assert_same_states(history, record, 'run', skip=MEASURED)
    assert_same_states(stepped.state, ran.state, 'state', skip=MEASURED)
    assert counts(ran) == counts(stepped)
    after = [simulation.step(rows[-1], EFFORT) for simulation in (stepped, ran)]
    assert_same_states(after[0], after[1], 'next step', skip=MEASURED)
    below, above, _, _ = counts(ran)
    assert below > 0 and above > 0  # the openings are clipped at both ends


@pytest.mark.parametrize('name', ('stroke', 'extensible patient'))
def test_each_glove_of_a_batch_behind_valves_steps_as_a_single_glove(name):
    model, count, steps = models()[name], 4, 60
    scales = np.linspace(0.05, 1.1, count)[:, None]
    batch = GloveSimulation(model, QUIET, count=count, actuation='valves')
    singles = [GloveSimulation(model, QUIET, actuation='valves') for _ in range(count)]
    for command, effort in zip(openings(steps), efforts(steps), strict=True):
        rows, pushes = scales * command, scales * effort
        state = batch.step(rows, pushes)
        alone = [single.step(rows[r], pushes[r]) for r, single in enumerate(singles)]
        for r, expected in enumerate(alone):
            assert_same_states(expected, glove_of(state, r), f'glove {r}', skip=('saturated',))
    assert batch.step_count == steps and np.ptp(state.mass[:, 0]) > 0.0


# -- 4. bad input to run() ------------------------------------------------------------------

T = 4
GOOD = np.full((T, 3), 10e3)
GOOD_BATCH = np.full((T, 3, 3), 10e3)


def spoiled(array, value, index):
    """A copy of ``array`` with ``value`` at ``index``."""
    copy = np.array(array, dtype=float)
    copy[index] = value
    return copy


def describe(value) -> str:
    """A short test id for a parameter: arrays by shape (and whether all finite)."""
    if isinstance(value, np.ndarray):
        finite = '' if np.all(np.isfinite(value)) else ' non-finite'
        return f'array{value.shape}{finite}'
    return repr(value)


@pytest.mark.parametrize(
    ('count', 'commands_', 'efforts_', 'argument'),
    [
        (None, np.zeros((T, 2)), None, 'commands'),
        (None, np.zeros(3), None, 'commands'),  # one command, not rows of them
        (None, np.zeros((T, 1, 3)), None, 'commands'),
        (None, 'abc', None, 'commands'),
        (None, [[1.0, 2.0, 3.0], [1.0, 2.0]], None, 'commands'),
        (None, spoiled(GOOD, np.nan, (2, 1)), None, 'commands'),
        (None, spoiled(GOOD, -np.inf, (0, 0)), None, 'commands'),
        (None, np.empty((0, 3)), None, 'commands'),
        (None, np.empty((0, 3)), np.empty((0, 3)), 'commands'),
        (None, GOOD, np.zeros((T - 1, 3)), 'efforts'),
        (None, GOOD, np.zeros((T, 2)), 'efforts'),
        (None, GOOD, np.zeros((T, 3, 1)), 'efforts'),
        (None, GOOD, spoiled(np.zeros((T, 3)), np.inf, (3, 2)), 'efforts'),
        (None, GOOD, 'abc', 'efforts'),
        (3, GOOD, None, 'commands'),  # rows of one glove for a batch
        (3, np.zeros((T, 2, 3)), None, 'commands'),
        (3, np.empty((0, 3, 3)), None, 'commands'),
        (3, None, None, 'commands'),
        (3, GOOD_BATCH, np.zeros((T - 1, 3, 3)), 'efforts'),
        (3, GOOD_BATCH, 'abc', 'efforts'),
        (3, spoiled(GOOD_BATCH, np.nan, (2, 1, 0)), None, 'commands'),
        (3, GOOD_BATCH, spoiled(np.zeros((T, 3, 3)), np.inf, (1, 0, 0)), 'efforts'),
        (3, 'abc', None, 'commands'),
        (3, [[[1.0, 2.0, 3.0]] * 3, [[1.0, 2.0, 3.0]] * 2], None, 'commands'),
        (3, GOOD_BATCH, [[[0.0, 0.0, 0.0]] * 3, [[0.0, 0.0, 0.0]] * 2], 'efforts'),
        (3, {'mcp': 1.0}, None, 'commands'),
    ],
    ids=describe,
)
def test_run_refuses_bad_input_naming_it_before_any_step(count, commands_, efforts_, argument):
    simulation = GloveSimulation(models()['default'], QUIET, count=count)
    rest = simulation.state
    with pytest.raises(ValueError, match=rf'\b{argument}\b'):
        simulation.run(commands_, efforts_)
    assert simulation.step_count == 0
    assert simulation.state is rest


@pytest.mark.skipif(not jit.JIT, reason='the kernels compile only with numba (EXODIGIT_JIT=1)')
def test_an_integer_rate_and_the_read_only_vent_compile_nothing_the_warm_up_did_not():
    # numba compiles a kernel once per argument types: an int rate or a read-only command would
    # each be a signature of their own, compiled by the first node that steps with them (40 s
    # on a fresh clone, behind the emulated board). They must reach the kernels as floats.
    def step(rate, command):
        settings = SimulationSettings(rate_hz=rate)
        GloveSimulation(settings=settings, actuation='valves').step(command)

    step(100.0, np.array(VENT))
    signatures = list(step_gloves.signatures)
    step(100, VENT)
    assert step_gloves.signatures == signatures
    assert type(SimulationSettings(rate_hz=100).rate_hz) is float


@pytest.mark.skipif(not jit.JIT, reason='the kernels compile only with numba (EXODIGIT_JIT=1)')
def test_a_read_only_force_target_compiles_nothing_the_warm_up_did_not():
    # The force mode's feed-forward passes its targets as a read-only broadcast.
    model, angles = GloveModel(), np.array([0.3, 0.4, 0.2])
    model.robot_contact_torque(angles, np.array([1.0, 2.0, 0.5]))
    signatures = list(robot_contact_torques.signatures)
    model.robot_contact_torque(angles, np.broadcast_to(np.array([1.0, 2.0, 0.5]), (3,)))
    assert robot_contact_torques.signatures == signatures
