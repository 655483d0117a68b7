"""The built-in controllers and the safety limiter (exodigit_model.control), without ROS."""

import numpy as np
import pytest
from exodigit_model.control import (
    Feedback,
    ForceController,
    Hold,
    PositionController,
    SafetyLimiter,
    SafetyLimits,
    Sine,
    Staircase,
)
from hypothesis import given, settings
from hypothesis import strategies as st

from exodigit_model import GloveModel, load_params, params_from_dict

#: Relative tolerance of closed-form comparisons (floating-point rounding only).
EXACT = 1e-12
#: Angle tolerance of checks that go through the coupled solver, rad.
SOLVE_TOLERANCE = 1e-9


@pytest.fixture(scope='module')
def model():
    return GloveModel(load_params())


def stiffer_finger_model(factor):
    data = load_params().to_dict()
    for joint in data['finger']['joints']:
        joint['stiffness'] *= factor
    return GloveModel(params_from_dict(data))


# -- controllers ---------------------------------------------------------------------------


def test_staircase_rises_in_10_kpa_steps_to_50_kpa_and_comes_back():
    staircase = Staircase(10e3, 50e3, 2.0)
    expected_kpa = [0, 10, 20, 30, 40, 50, 40, 30, 20, 10, 0, 10]
    for i, level in enumerate(expected_kpa):
        for t in (2.0 * i + 0.01, 2.0 * i + 1.99):
            np.testing.assert_array_equal(
                staircase.desired(t, Feedback(), 0.01), [level * 1e3] * 3
            )


def test_sine_moves_between_its_two_pressures():
    sine = Sine(5e3, 45e3, 4.0)
    assert sine.desired(0.0, Feedback(), 0.01) == pytest.approx([5e3] * 3, rel=EXACT)
    assert sine.desired(1.0, Feedback(), 0.01) == pytest.approx([25e3] * 3, rel=EXACT)
    assert sine.desired(2.0, Feedback(), 0.01) == pytest.approx([45e3] * 3, rel=EXACT)
    np.testing.assert_array_equal(Hold([1.0, 2.0, 3.0]).desired(5.0, Feedback(), 0.01), [1, 2, 3])


def test_position_feedforward_holds_the_target_on_the_modelled_finger(model):
    targets = np.array([0.4, 0.3, 0.2])
    controller = PositionController(model, targets, 2e4, 5e4)
    pressure = controller.desired(0.0, Feedback(angles=targets), 0.01)
    solution = model.solve(pressure)
    assert solution.converged
    np.testing.assert_allclose(solution.q, targets, atol=SOLVE_TOLERANCE)


def test_position_loop_removes_the_error_of_a_wrong_finger_model(model):
    plant = stiffer_finger_model(1.5)  # the real finger is 50 % stiffer than the model says
    targets = np.array([0.4, 0.3, 0.2])
    controller = PositionController(model, targets, 5e4, 3e5)
    limits = SafetyLimits(100e3, 1e6, (-0.5,) * 3, (2.0,) * 3, 50.0)
    limiter, angles, dt = SafetyLimiter(limits), np.zeros(3), 0.01
    for step in range(800):
        desired = controller.desired(step * dt, Feedback(angles=angles), dt)
        sent = limiter.apply(desired, dt, angles).pressure
        controller.commit(desired, sent)
        angles = plant.solve(sent, q0=angles).q
    np.testing.assert_allclose(angles, targets, atol=1e-4)


def test_force_feedforward_makes_the_robot_side_estimate_equal_the_target(model):
    targets = np.array([0.2, -0.1, 0.3])
    controller = ForceController(model, targets, 1e4, 2e4)
    angles = np.array([0.3, 0.25, 0.1])
    pressure = controller.feedforward(angles)
    np.testing.assert_allclose(model.estimate_forces(angles, pressure), targets, atol=1e-12)


def test_force_loop_reaches_the_target_forces(model):
    targets = np.array([0.1, 0.1, 0.3])
    controller = ForceController(model, targets, 5e4, 5e5)
    limiter = SafetyLimiter(SafetyLimits(100e3, 1e6, (-0.5,) * 3, (2.0,) * 3, 50.0))
    angles, forces, dt = np.zeros(3), np.zeros(3), 0.01
    for step in range(800):
        desired = controller.desired(step * dt, Feedback(angles, forces), dt)
        sent = limiter.apply(desired, dt, angles, forces).pressure
        controller.commit(desired, sent)
        solution = model.solve(sent, q0=angles)
        angles, forces = solution.q, solution.forces
    np.testing.assert_allclose(forces, targets, atol=1e-4)


def test_integrator_does_not_wind_up_against_a_limit(model):
    controller = PositionController(model, [0.4, 0.3, 0.2], 0.0, 1e4)
    error_feedback = Feedback(angles=np.zeros(3))
    raw = controller.desired(0.0, error_feedback, 0.01)
    controller.commit(raw, raw - 1.0)  # every chamber clipped from above while error > 0
    np.testing.assert_array_equal(controller.integral, np.zeros(3))
    raw = controller.desired(0.0, error_feedback, 0.01)
    controller.commit(raw, raw)
    np.testing.assert_allclose(controller.integral, [0.004, 0.003, 0.002], rtol=EXACT)


# -- safety limiter ------------------------------------------------------------------------

LIMITS = SafetyLimits(60e3, 100e3, (-0.1, -0.1, -0.1), (1.5, 1.7, 1.4), 5.0)
hostile = st.floats(allow_nan=True, allow_infinity=True, width=64)


@settings(max_examples=200, deadline=None)
@given(
    requests=st.lists(st.lists(hostile, min_size=3, max_size=3), min_size=1, max_size=20),
    dt=st.floats(0.0, 0.1),
)
def test_limiter_output_stays_in_range_rate_and_finite(requests, dt):
    limiter = SafetyLimiter(LIMITS)
    last = np.zeros(3)
    for request in requests:
        sent = limiter.apply(np.array(request), dt).pressure
        assert np.isfinite(sent).all()
        assert (sent >= 0.0).all() and (sent <= LIMITS.max_pressure).all()
        assert (np.abs(sent - last) <= LIMITS.max_pressure_rate * dt * (1 + 1e-12)).all()
        last = sent


def test_limiter_backs_off_outside_the_range_of_motion_or_above_the_force_limit():
    limiter = SafetyLimiter(LIMITS)
    for _ in range(100):
        limiter.apply(np.full(3, 40e3), 0.01)
    np.testing.assert_allclose(limiter.last, 40e3)
    out = limiter.apply(np.full(3, 40e3), 0.01, angles=np.array([0.2, 1.8, 0.1]))
    np.testing.assert_allclose(out.pressure, 39e3)
    assert 'pip' in out.reasons['back-off']
    out = limiter.apply(np.full(3, 40e3), 0.01, forces=np.array([0.0, -6.0, 0.0]))
    np.testing.assert_allclose(out.pressure, 38e3)
    assert 'contact force' in out.reasons['back-off']


def test_after_a_back_off_the_command_stays_capped_until_the_controller_asks_for_less():
    limiter = SafetyLimiter(LIMITS)
    limiter.last = np.full(3, 40e3)
    outside = np.array([1.6, 0.5, 0.5])  # mcp beyond 1.5 rad
    inside = np.array([1.4, 0.5, 0.5])
    for _ in range(5):
        limiter.apply(np.full(3, 45e3), 0.01, angles=outside)
    np.testing.assert_allclose(limiter.last, 35e3)
    for _ in range(20):  # back inside, the controller still asks for more
        out = limiter.apply(np.full(3, 45e3), 0.01, angles=inside)
        np.testing.assert_allclose(out.pressure, 35e3)
        assert 'ceiling' in out.reasons
    out = limiter.apply(np.full(3, 30e3), 0.01, angles=inside)  # asks for less: cap released
    np.testing.assert_allclose(out.pressure, 34e3)
    assert 'ceiling' not in out.reasons
    out = limiter.apply(np.full(3, 45e3), 0.01, angles=inside)
    np.testing.assert_allclose(out.pressure, 35e3)


def test_lowering_max_pressure_clips_at_once():
    limiter = SafetyLimiter(LIMITS)
    limiter.last = np.full(3, 50e3)
    limiter.limits = SafetyLimits(20e3, 100e3, (-0.1,) * 3, (1.5,) * 3, 5.0)
    np.testing.assert_array_equal(limiter.apply(np.full(3, 50e3), 0.01).pressure, [20e3] * 3)


def test_limits_refuse_an_empty_range_of_motion():
    with pytest.raises(ValueError, match='joint_lower_limits'):
        SafetyLimits(60e3, 1e5, (0.0, 0.5, 0.0), (1.0, 0.4, 1.0), 5.0)
