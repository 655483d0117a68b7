"""The stepper (docs/spec/model.md §13): chambers, warm-started solves, sensors, time, batches.

Every expectation is computed independently: the chamber pressure from the continuous step
response of T·dp/dt = u − p, the angles by the reference residual of eq 36
(tests/model_reference.py), velocities by differences, time from t_k = round(k·10⁹/rate).
"""

import math

import numpy as np
import pytest
from exodigit_model.kernels.newton import CONVERGED_STEP
from exodigit_model.kernels.stepping import step_one
from exodigit_model.physics.model import VALID_STRETCH
from model_reference import coupled_residual

from exodigit_model import (
    ChamberSettings,
    GloveModel,
    GloveSimulation,
    SimulationSettings,
    load_params,
    params_from_dict,
)

PARAMS = load_params()
MODEL = GloveModel(PARAMS)
#: Relative tolerance of closed-form comparisons (rounding only).
EXACT = 1e-12
#: Largest reference residual of eq 36 accepted at a solved state, N·m.
RESIDUAL_TOLERANCE = 1e-10
#: Angle agreement between two converged solves of the same equation, rad.
ANGLE_TOLERANCE = 1e-10
#: Contact-force agreement between two converged solves (the angle tolerance's worth), N.
FORCE_TOLERANCE = 1e-10


def ideal(**changes):
    """Settings without lag or noise (the testing kit's defaults), with ``changes``."""
    return SimulationSettings(pressure_time_constant=0.0, **changes)


def sine_commands(steps, peak=40e3, period=200):
    phase = 2 * math.pi * np.arange(1, steps + 1) / period  # never exactly zero
    return 0.5 * peak * (1.0 - np.cos(phase))[:, None] * np.array([1.0, 0.8, 0.6])


# -- chambers ------------------------------------------------------------------------------


def test_chamber_lag_matches_the_continuous_step_response():
    constant, command = 0.05, np.array([10e3, 30e3, 50e3])
    simulation = GloveSimulation(settings=SimulationSettings(pressure_time_constant=constant))
    for n in range(1, 41):
        pressure = simulation.step(command).pressure
        expected = command * (1.0 - math.exp(-n * 0.01 / constant))
        np.testing.assert_allclose(pressure, expected, rtol=EXACT)


def test_ideal_chambers_follow_the_command_at_once_and_saturate_reporting_it():
    simulation = GloveSimulation(settings=SimulationSettings(pressure_time_constant=0.0))
    state = simulation.step(np.array([1e3, 2e3, 3e3]))
    np.testing.assert_array_equal(state.pressure, [1e3, 2e3, 3e3])
    assert not state.saturated
    state = simulation.step(np.array([-5.0, 50e3, 2e5]))
    np.testing.assert_array_equal(state.pressure, [0.0, 50e3, 100e3])
    np.testing.assert_array_equal(state.command, [0.0, 50e3, 100e3])
    assert state.saturated
    saturation = simulation.chambers.saturation
    assert (saturation.below_zero, saturation.above_supply) == (1, 1)
    np.testing.assert_array_equal(simulation.reset().pressure, np.zeros(3))


@pytest.mark.parametrize(
    ('field', 'value'), [('time_constant', -1.0), ('max_supply_pressure', 0.0)]
)
def test_chamber_settings_refuse_bad_values_naming_them(field, value):
    with pytest.raises(ValueError, match=field):
        ChamberSettings(**{field: value})


# -- one glove -----------------------------------------------------------------------------


#: The reference residual of eq 36 (adaptive quadrature, about 15 ms) is evaluated at the first
#: step and every this many after it; everything else is checked at every step.
RESIDUAL_EVERY = 5


def test_each_step_solves_eq_36_at_the_lagged_pressure_and_reports_it():
    """Every step: the lagged pressure, qdot, time, flags and sensors; at the first step and
    every RESIDUAL_EVERY-th (31 of the 150, warm starts from rising and falling pressure), the
    reference residual of eq 36 at the reported state."""
    settings = SimulationSettings(rate_hz=100.0, pressure_time_constant=0.05)
    simulation = GloveSimulation(MODEL, settings)
    commands = sine_commands(150)
    expected_pressure = np.zeros(3)
    decay = math.exp(-0.01 / 0.05)
    previous = simulation.state.q
    for k, command in enumerate(commands, start=1):
        state = simulation.step(command)
        expected_pressure = command + (expected_pressure - command) * decay
        np.testing.assert_allclose(state.pressure, expected_pressure, rtol=EXACT, atol=1e-9)
        if k == 1 or k % RESIDUAL_EVERY == 0:
            residual = coupled_residual(PARAMS, state.q, state.pressure)
            assert np.abs(residual).max() < RESIDUAL_TOLERANCE, k
        np.testing.assert_allclose(state.qdot, (state.q - previous) / 0.01, rtol=EXACT)
        assert state.time_ns == round(k * 1e9 / 100.0) and state.step == k
        assert state.converged and state.in_valid_range
        np.testing.assert_array_equal(state.q_measured, state.q)  # no noise configured
        np.testing.assert_array_equal(state.pressure_measured, state.pressure)
        previous = state.q


def test_a_warm_started_step_equals_a_cold_solve_at_the_same_pressure():
    simulation = GloveSimulation(MODEL, ideal())
    for command in sine_commands(60):
        state = simulation.step(command)
        cold = MODEL.solve(state.pressure)
        np.testing.assert_allclose(state.q, cold.q, rtol=0, atol=ANGLE_TOLERANCE)
        np.testing.assert_allclose(state.forces, cold.forces, rtol=0, atol=FORCE_TOLERANCE)
        stiffness = np.array([joint.stiffness for joint in PARAMS.finger.joints])
        np.testing.assert_allclose(state.finger_torque, stiffness * state.q, rtol=EXACT)


def test_a_step_after_a_held_then_vented_chamber_equals_a_cold_solve():
    # A chamber held for two steps and vented, then another one: angles rest, A, A, rest. The
    # third difference of that history is zero, though it is no smooth motion; a start
    # predicted from it put the dip at twice -A (hyperextended) and the solve failed there.
    commands = np.array([[0, 0, 100e3], [0, 0, 100e3], [0, 0, 0], [100e3, 0, 0]])
    single = GloveSimulation(MODEL, ideal())
    batch = GloveSimulation(MODEL, ideal(), count=2)  # the same history, chambers swapped
    for command in commands:
        cold = [MODEL.solve(command).q, MODEL.solve(command[::-1]).q]
        state, states = single.step(command), batch.step([command, command[::-1]])
        assert state.converged and np.all(states.converged), command
        np.testing.assert_allclose(state.q, cold[0], rtol=0, atol=ANGLE_TOLERANCE)
        np.testing.assert_allclose(states.q, cold, rtol=0, atol=ANGLE_TOLERANCE)


def test_a_predicted_start_that_fails_is_solved_again_from_the_last_good_angles():
    # A glove at rest whose angles before moved in a straight line (a smooth motion), 1.1 rad
    # a step with the dip backwards: the solve starts one such step past rest, where Newton
    # finds no descent at 100 kPa on the MCP chamber. From the last good angles it converges.
    # (The state is made up: the kernel's own input, not one a simulation reaches.)
    pressure = np.array([100e3, 0.0, 0.0])
    moved = np.array([0.075, -0.138, -1.125])
    block = np.zeros((9, 3))  # at rest: x, f, τ_H and the pressures are 0 (step_one's layout)
    block[1, :3], block[7, :3], block[8, :3] = -moved, -2 * moved, -3 * moved
    limits = (0.0, 100e3, 100.0, *VALID_STRETCH)  # an ideal chamber, its supply, 1/Δt
    new, (status, *_) = step_one(MODEL.packed, block, pressure, np.zeros(3), *limits)
    assert status <= CONVERGED_STEP
    np.testing.assert_allclose(new[0], MODEL.solve(pressure).q, rtol=0, atol=ANGLE_TOLERANCE)


@pytest.mark.parametrize('rate_hz', [100.0, 3.0, 7.0, 999.0])
def test_step_times_follow_the_rounded_grid_without_drift(rate_hz):
    simulation = GloveSimulation(MODEL, ideal(rate_hz=rate_hz))
    times = [simulation.step(np.zeros(3)).time_ns for _ in range(500)]
    assert times == [round(k * 1e9 / rate_hz) for k in range(1, 501)]
    assert simulation.state.t == times[-1] / 1e9
    run = GloveSimulation(MODEL, ideal(rate_hz=rate_hz)).run(np.zeros((500, 3)))
    assert run.time_ns.tolist() == times  # computed for the whole run at once


def test_saturated_commands_are_clipped_and_flagged():
    simulation = GloveSimulation(MODEL, ideal(max_supply_pressure=50e3))
    state = simulation.step([80e3, -1e3, 20e3])
    assert state.saturated
    np.testing.assert_array_equal(state.command, [50e3, 0.0, 20e3])
    np.testing.assert_array_equal(state.pressure, [50e3, 0.0, 20e3])
    assert not simulation.step([10e3, 10e3, 10e3]).saturated


def test_reset_returns_to_rest_without_rewinding_time():
    simulation = GloveSimulation(MODEL, SimulationSettings())
    for command in sine_commands(30):
        simulation.step(command)
    before = simulation.state.time_ns
    rest = simulation.reset()
    assert rest.time_ns == before and rest.step == 30
    np.testing.assert_array_equal(rest.pressure, np.zeros(3))
    np.testing.assert_array_equal(rest.q, np.zeros(3))  # rest angle 0: q = 0 at p = 0
    after = simulation.step(np.zeros(3))
    assert after.time_ns == round(31 * 1e7)
    np.testing.assert_array_equal(after.q, np.zeros(3))


def test_a_solve_that_fails_keeps_the_last_good_state_and_says_so():
    # A silicone of C1 = 1 Pa holds 5 kPa on the finger but not 100 kPa (test_model_solver).
    soft = GloveModel(params_from_dict({'material': {'c1': 1.0, 'c2': 0.0, 'c3': 0.0}}))
    simulation = GloveSimulation(soft, ideal())
    good = simulation.step([5e3, 5e3, 5e3])
    failed = simulation.step([100e3, 100e3, 100e3])
    assert not failed.converged and math.isfinite(failed.residual)
    np.testing.assert_array_equal(failed.q, good.q)
    np.testing.assert_array_equal(failed.qdot, np.zeros(3))
    assert simulation.solver_failures == 1
    recovered = simulation.step([5e3, 5e3, 5e3])
    assert recovered.converged
    np.testing.assert_allclose(recovered.q, good.q, atol=ANGLE_TOLERANCE)


# -- sensors -------------------------------------------------------------------------------


def noisy_run(seed, steps=400, **noise):
    settings = SimulationSettings(seed=seed, **noise)
    simulation = GloveSimulation(MODEL, settings)
    return [simulation.step(command) for command in sine_commands(steps)]


def test_sensor_noise_is_seeded_bit_for_bit_and_leaves_the_true_state_alone():
    noise = {'angle_noise_std': 1e-3, 'pressure_noise_std': 200.0}
    first, again, other = noisy_run(7, **noise), noisy_run(7, **noise), noisy_run(8, **noise)
    quiet = noisy_run(7)
    for a, b, c, truth in zip(first, again, other, quiet, strict=True):
        np.testing.assert_array_equal(a.q_measured, b.q_measured)
        np.testing.assert_array_equal(a.pressure_measured, b.pressure_measured)
        assert not np.array_equal(a.q_measured, c.q_measured)
        np.testing.assert_array_equal(a.q, truth.q)  # the noise never feeds back
    angle_error = np.array([s.q_measured - s.q for s in first])
    pressure_error = np.array([s.pressure_measured - s.pressure for s in first])
    assert abs(angle_error.std() / 1e-3 - 1.0) < 0.1
    assert abs(pressure_error.std() / 200.0 - 1.0) < 0.1
    assert abs(angle_error.mean()) < 5 * 1e-3 / math.sqrt(angle_error.size)


def test_one_quiet_sensor_does_not_change_the_others_noise():
    both = noisy_run(3, angle_noise_std=1e-3, pressure_noise_std=200.0)
    angle_only = noisy_run(3, angle_noise_std=1e-3)
    for a, b in zip(both, angle_only, strict=True):
        np.testing.assert_array_equal(a.q_measured, b.q_measured)


# -- batches -------------------------------------------------------------------------------


def test_a_batch_steps_each_glove_as_a_single_simulation_would():
    count = 5
    scales = np.linspace(0.2, 1.0, count)
    batch = GloveSimulation(MODEL, SimulationSettings(), count=count)
    singles = [GloveSimulation(MODEL, SimulationSettings()) for _ in range(count)]
    for command in sine_commands(80):
        rows = scales[:, None] * command
        state = batch.step(rows)
        assert state.q.shape == (count, 3) and state.converged.shape == (count,)
        for row, single in enumerate(singles):
            expected = single.step(rows[row])
            np.testing.assert_allclose(state.pressure[row], expected.pressure, rtol=EXACT)
            np.testing.assert_allclose(state.q[row], expected.q, rtol=0, atol=ANGLE_TOLERANCE)
            np.testing.assert_allclose(
                state.forces[row], expected.forces, rtol=0, atol=FORCE_TOLERANCE
            )
    assert batch.state.time_ns == singles[0].state.time_ns


def test_a_batch_of_one_keeps_its_row_shape():
    state = GloveSimulation(MODEL, ideal(), count=1).step([[10e3, 10e3, 10e3]])
    assert state.q.shape == (1, 3)


# -- input checks --------------------------------------------------------------------------


@pytest.mark.parametrize(
    'command', [[1.0, 2.0], [np.nan, 0.0, 0.0], 'abc', [[1.0, 2.0, 3.0]]], ids=repr
)
def test_a_bad_command_is_refused_naming_it(command):
    with pytest.raises(ValueError, match='command'):
        GloveSimulation(MODEL).step(command)


def test_a_batch_refuses_the_wrong_number_of_rows():
    with pytest.raises(ValueError, match=r'shape \(4, 3\)'):
        GloveSimulation(MODEL, count=4).step(np.zeros((3, 3)))


@pytest.mark.parametrize(
    ('field', 'value'),
    [
        ('rate_hz', 0.0),
        ('pressure_time_constant', -0.1),
        ('max_supply_pressure', 0.0),
        ('angle_noise_std', math.inf),
        ('seed', 1.5),
        ('seed', True),
    ],
)
def test_settings_refuse_bad_values_naming_them(field, value):
    with pytest.raises(ValueError, match=field):
        SimulationSettings(**{field: value})


@pytest.mark.parametrize('count', [0, -2, 1.5, True])
def test_a_bad_count_is_refused(count):
    with pytest.raises(ValueError, match='count'):
        GloveSimulation(MODEL, count=count)


def test_configure_changes_the_lag_but_not_the_time_grid_or_seed():
    simulation = GloveSimulation(MODEL, SimulationSettings(pressure_time_constant=0.05))
    simulation.configure(pressure_time_constant=0.0)
    np.testing.assert_array_equal(simulation.step([20e3, 20e3, 20e3]).pressure, [20e3] * 3)
    for fixed in ('rate_hz', 'seed'):
        with pytest.raises(ValueError, match=fixed):
            simulation.configure(**{fixed: 1})
    with pytest.raises(ValueError, match='max_supply_pressure'):
        simulation.configure(max_supply_pressure=-1.0)
