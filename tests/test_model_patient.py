"""The patient (docs/spec/model.md §11): τ_H, stepped solve (11.4), inverse, estimators, fits.

Independent references: tests/model_reference.py (τ_H written from the document with numpy,
F of 11.4 by quadrature and eq 4), central differences, independent solves of equivalent
problems, and the defaults' linear model.
"""

import math

import numpy as np
import pytest
from exodigit_model.kernels.constants import LAW_REST_ANGLE
from exodigit_model.kernels.patient import finger_torque as joint_torque
from model_reference import (
    EVERY_TERM,
    coupled_residual,
    finger_torque,
    printed_finger_jacobian_transposed,
)

from exodigit_model import (
    GloveModel,
    GloveSimulation,
    ParameterError,
    SimulationSettings,
    load_params,
    params_from_dict,
)

NOMINAL = GloveModel(load_params())
#: Relative agreement of results that must be the same arithmetic.
EXACT = 1e-12
#: Central-difference step (rad, rad/s) and the agreement expected from it.
STEP, DIFFERENCE_RTOL = 1e-6, 1e-6
#: Reference residual of 11.4 accepted at a solved state, N·m.
RESIDUAL_TOLERANCE = 1e-10
#: Angle agreement between two converged solves of equivalent problems, rad.
ANGLE_TOLERANCE = 1e-10
DT = 0.01  # s


def patient(**terms):
    """The default glove on a finger whose three joints all get ``terms``."""
    return params_from_dict({'finger': {'joints': [dict(terms) for _ in range(3)]}})


def model_of(**terms):
    return GloveModel(patient(**terms))


FULL = patient(**EVERY_TERM)
FULL_MODEL = GloveModel(FULL)


# -- τ_H -------------------------------------------------------------------------------------


@pytest.mark.parametrize('qdot', [None, [0.0, 0.0, 0.0], [0.8, -0.6, 0.1], [-2.0, 2.0, -0.2]])
@pytest.mark.parametrize('q', [[0.1, 0.3, 0.2], [1.5, 1.6, 1.3], [-0.3, 0.01, 0.05]])
def test_finger_torque_follows_eqs_11_1_to_11_3(q, qdot):
    effort = [0.01, -0.02, 0.003]
    np.testing.assert_allclose(
        FULL_MODEL.finger_torque(q, qdot, effort),
        finger_torque(FULL, q, qdot, effort),
        rtol=EXACT,
        atol=1e-15,
    )


def test_defaults_are_the_papers_linear_spring():
    q = np.array([0.4, -0.2, 0.9])
    stiffness = np.array([joint.stiffness for joint in NOMINAL.params.finger.joints])
    np.testing.assert_array_equal(NOMINAL.finger_torque(q, [3.0, -3.0, 1.0]), stiffness * q)


def test_stiffening_and_spasticity_slopes_equal_differences():
    for law in FULL_MODEL.constants.laws:
        for q in (-0.3, 0.2, 1.2):
            _, slope = joint_torque(law, q, 0.0, 0.0)
            up, _ = joint_torque(law, q + STEP, 0.0, 0.0)
            down, _ = joint_torque(law, q - STEP, 0.0, 0.0)
            assert slope == pytest.approx((up - down) / (2 * STEP), rel=DIFFERENCE_RTOL)
        for v in (-1.0, -0.31, 0.0, 0.29, 2.0):
            # with dq̇/dq = 1 the slope gains exactly dτ_H/dq̇
            rate_slope = joint_torque(law, 0.2, v, 1.0)[1] - joint_torque(law, 0.2, v, 0.0)[1]
            up, _ = joint_torque(law, 0.2, v + STEP, 0.0)
            down, _ = joint_torque(law, 0.2, v - STEP, 0.0)
            assert rate_slope == pytest.approx(
                (up - down) / (2 * STEP), rel=DIFFERENCE_RTOL, abs=1e-9
            )
        assert joint_torque(law, law[LAW_REST_ANGLE], 0.0, 1.0)[0] == 0.0  # exactly zero at rest


# -- the coupled equation --------------------------------------------------------------------


def test_with_every_new_parameter_at_its_default_nothing_changes():
    explicit = GloveModel(
        patient(
            rest_angle=0.0,
            rom_torque=0.0,
            damping=0.0,
            spasticity=0.0,
            extensor_spasticity=0.0,
        )
    )
    previous = np.array([0.1, 0.05, 0.02])
    for p in ([10e3, 20e3, 30e3], [50e3, 50e3, 50e3]):
        static = NOMINAL.solve(p)
        stepped = explicit.solve(p, np.zeros(3), q_previous=previous, dt=DT)
        np.testing.assert_allclose(stepped.q, static.q, rtol=EXACT)
        np.testing.assert_allclose(stepped.forces, static.forces, rtol=EXACT)
        # from another start the same equation, to solver tolerance
        warm = explicit.solve(p, q_previous=previous, dt=DT)
        np.testing.assert_allclose(warm.q, static.q, rtol=0, atol=ANGLE_TOLERANCE)
        assert np.abs(coupled_residual(NOMINAL.params, static.q, np.array(p))).max() < (
            RESIDUAL_TOLERANCE
        )


def test_the_stepped_solve_solves_eq_11_4_with_every_term_on():
    previous = np.array([0.3, 0.35, 0.25])
    p = np.array([40e3, 30e3, 20e3])
    effort = np.array([0.005, -0.004, 0.002])
    solution = FULL_MODEL.solve(p, effort=effort, q_previous=previous, dt=DT)
    assert solution.converged, solution.message
    qdot = (solution.q - previous) / DT
    assert np.abs(coupled_residual(FULL, solution.q, p, qdot, effort)).max() < RESIDUAL_TOLERANCE
    np.testing.assert_allclose(
        printed_finger_jacobian_transposed(FULL, solution.q) @ solution.forces,
        finger_torque(FULL, solution.q, qdot, effort),
        rtol=1e-9,
    )


def test_the_jacobian_of_eq_11_4_equals_differences_of_the_residual():
    previous = np.array([0.2, 0.4, 0.1])
    kwargs = {'effort': [0.01, 0.0, -0.005], 'q_previous': previous, 'dt': DT}
    p = np.array([30e3, 20e3, 10e3])
    for q in (np.array([0.25, 0.38, 0.15]), np.array([1.3, 1.5, 1.2])):
        analytic = FULL_MODEL.residual_jacobian(q, p, **kwargs)
        numeric = np.column_stack(
            [
                (
                    FULL_MODEL.residual(q + STEP * e, p, **kwargs)
                    - FULL_MODEL.residual(q - STEP * e, p, **kwargs)
                )
                / (2 * STEP)
                for e in np.eye(3)
            ]
        )
        np.testing.assert_allclose(analytic, numeric, rtol=DIFFERENCE_RTOL, atol=1e-9)


def test_range_of_motion_stiffening_holds_the_joints_inside_their_range():
    rom = {'rom_max': 0.3, 'rom_min': -0.1}
    free = model_of(**rom).solve([100e3] * 3)
    assert free.converged and (free.q > 0.3).any() and not free.in_range_of_motion
    held = model_of(**rom, rom_torque=0.1, rom_sharpness=50.0).solve([100e3] * 3)
    assert held.converged and held.in_range_of_motion, held.q
    assert (held.q <= 0.3).all()
    assert 'range of motion' in free.warnings()[-1] and held.warnings() == []


def test_an_effort_moves_the_equilibrium_as_a_shifted_rest_angle_would():
    # A linear joint with effort u needs k (q − q_r) − u = k (q − (q_r + u/k)).
    k = np.array([joint.stiffness for joint in NOMINAL.params.finger.joints])
    effort = np.array([0.004, 0.002, 0.001])  # N·m; shifted rest angles stay in range
    shifted = params_from_dict(
        {'finger': {'joints': [{'rest_angle': float(a)} for a in effort / k]}}
    )
    for p in ([20e3, 20e3, 20e3], [50e3, 30e3, 10e3]):
        with_effort = NOMINAL.solve(p, effort=effort)
        moved = GloveModel(shifted).solve(p)
        np.testing.assert_allclose(with_effort.q, moved.q, rtol=0, atol=ANGLE_TOLERANCE)


# -- time: damping and spasticity ------------------------------------------------------------


def step_response(model, steps=200, command=40e3, time_constant=0.0):
    settings = SimulationSettings(pressure_time_constant=time_constant)
    simulation = GloveSimulation(model, settings)
    return np.array([simulation.step([command] * 3).q for _ in range(steps)])


def test_damping_slows_a_pressure_step_which_settles_at_the_static_solution():
    damped = model_of(damping=0.02)
    static = damped.solve([40e3] * 3).q
    undamped = step_response(NOMINAL, steps=400)
    slow = step_response(damped, steps=400)
    np.testing.assert_allclose(undamped[0], NOMINAL.solve([40e3] * 3).q, atol=ANGLE_TOLERANCE)
    assert (slow[0] < 0.5 * static).all()  # the first step moves less than half way
    np.testing.assert_allclose(slow[-1], static, rtol=0, atol=1e-6)


def vent_lag(model, time_constant):
    """Largest lag of the joints behind the quasi-static return after venting from 50 kPa."""
    settings = SimulationSettings(pressure_time_constant=time_constant)
    simulation = GloveSimulation(model, settings)
    for _ in range(300):
        simulation.step([50e3] * 3)
    lags = []
    for _ in range(300):
        state = simulation.step([0.0] * 3)
        static = NOMINAL.solve(state.pressure, q0=state.q).q
        lags.append(np.max(state.q - static))
    return max(lags)


def test_spasticity_resists_a_fast_stretch_more_than_a_slow_one():
    spastic = model_of(spasticity=0.05, spasticity_threshold=0.2)
    fast, slow = vent_lag(spastic, 0.01), vent_lag(spastic, 1.0)
    assert vent_lag(NOMINAL, 0.01) < 1e-9  # without spasticity the return is quasi-static
    assert fast > 5.0 * slow and fast > math.radians(1.0)


# -- inverse, estimators, identification -----------------------------------------------------


def test_inverse_and_estimators_round_trip_with_every_term_on():
    previous = np.array([0.3, 0.35, 0.25])
    effort = np.array([0.003, 0.001, -0.001])
    p = np.array([35e3, 25e3, 15e3])
    solution = FULL_MODEL.solve(p, effort=effort, q_previous=previous, dt=DT)
    qdot = (solution.q - previous) / DT
    np.testing.assert_allclose(
        FULL_MODEL.pressure_for(solution.q, qdot, effort), p, rtol=1e-9, atol=1e-6
    )
    np.testing.assert_allclose(
        FULL_MODEL.estimate_forces(solution.q, p), solution.forces, rtol=1e-9, atol=1e-12
    )
    np.testing.assert_allclose(
        FULL_MODEL.finger_forces(solution.q, qdot, effort), solution.forces, rtol=1e-9
    )
    np.testing.assert_allclose(
        FULL_MODEL.estimate_finger_torque(solution.q, p),
        finger_torque(FULL, solution.q, qdot, effort),
        rtol=1e-9,
        atol=1e-12,
    )


def samples_of(model, count, rng, noise=0.0):
    pressures = rng.uniform(2e3, 60e3, (count, 3))
    angles = model.solve_batch(pressures).q
    return angles + rng.normal(0.0, noise, angles.shape), pressures


def test_identification_recovers_stiffness_and_rest_angle_within_their_errors():
    rest = {'rest_angle': 0.2, 'stiffness': 0.06}
    linear = model_of(**rest)
    angles, pressures = samples_of(linear, 200, np.random.default_rng(4), noise=2e-4)
    fit = NOMINAL.fit_stiffness(angles, pressures)
    assert np.all(np.abs(fit.stiffness - 0.06) < 4.0 * fit.standard_error)
    assert np.all(np.abs(fit.rest_angle - 0.2) < 4.0 * fit.rest_angle_standard_error)
    assert np.all(fit.standard_error < 0.05 * 0.06)  # and the errors are informative
    exact = NOMINAL.fit_stiffness(*samples_of(linear, 50, np.random.default_rng(5)))
    np.testing.assert_allclose(exact.stiffness, 0.06, rtol=1e-7)
    np.testing.assert_allclose(exact.rest_angle, 0.2, atol=1e-7)
    assert np.all(exact.rmse < 1e-9)


def test_identification_reports_a_larger_rmse_for_a_patient_that_is_no_spring():
    rng = np.random.default_rng(6)
    stiffening = model_of(rom_torque=0.01, rom_sharpness=25.0, rom_max=0.5)
    linear_fit = NOMINAL.fit_stiffness(*samples_of(NOMINAL, 100, rng))
    nonlinear_fit = NOMINAL.fit_stiffness(*samples_of(stiffening, 100, rng))
    assert np.all(nonlinear_fit.rmse > 100.0 * np.maximum(linear_fit.rmse, 1e-15))
    assert nonlinear_fit.rmse.max() > 1e-4  # N·m: visible beside the torques (~1e-2 N·m)


# -- parameters -------------------------------------------------------------------------------


@pytest.mark.parametrize(
    ('terms', 'fragment'),
    [
        ({'rest_angle': 2.0}, r'rest_angle = 2\.0.*range of motion'),
        ({'rom_min': 0.5, 'rom_max': 0.4}, r'rom_min = 0\.5.*below rom_max'),
        ({'rom_torque': -1.0}, r'rom_torque = -1\.0.*>= 0'),
        ({'damping': -0.1}, r'damping.*>= 0'),
        ({'spasticity': -0.1}, r'spasticity.*>= 0'),
        ({'extensor_spasticity': -0.1}, r'extensor_spasticity.*>= 0'),
        ({'rom_sharpness': 0.0}, r'rom_sharpness.*> 0'),
        ({'spasticity_threshold': 0.0}, r'spasticity_threshold.*> 0'),
        ({'rest_angle': 'flexed'}, r'rest_angle.*number'),
    ],
)
def test_patient_parameters_are_validated_naming_key_value_and_rule(terms, fragment):
    with pytest.raises(ParameterError, match=r'finger\.joints\[0\]\.' + fragment):
        params_from_dict({'finger': {'joints': [terms, {}, {}]}})


@pytest.mark.parametrize(
    ('kwargs', 'fragment'),
    [
        ({'q_previous': [0.0, 0.0, 0.0]}, 'together'),
        ({'dt': 0.01}, 'together'),
        ({'q_previous': [0.0, 0.0, 0.0], 'dt': 0.0}, 'dt'),
        ({'effort': [0.0, math.nan, 0.0]}, 'effort'),
    ],
)
def test_a_bad_stepped_solve_is_refused_naming_the_argument(kwargs, fragment):
    with pytest.raises(ValueError, match=fragment):
        NOMINAL.solve([10e3] * 3, **kwargs)


def test_each_named_law_column_holds_the_parameter_of_its_name():
    # one table: the LAW_* indices the kernels read by and the parameters law_row copies in
    from exodigit_model.kernels import constants

    joint = FULL_MODEL.params.finger.joints[1]
    row = FULL_MODEL.constants.laws[1]
    for name in constants.LAW_PARAMETERS:
        assert row[getattr(constants, f'LAW_{name.upper()}')] == getattr(joint, name)
