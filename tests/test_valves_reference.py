"""The reference of docs/spec/model.md §14 (tests/valves_reference.py) checked where it can be.

The reference integration against closed forms on rigid chambers (the choked fill is linear in
time; the vent time is a quadrature of 1/Q), the flow function at its joints, and its fast
statics against the adaptive quadrature and finite differences of tests/model_reference.py, so
that tests/test_model_valves_convergence.py compares the model with something checked.
"""

import math

import numpy as np
import pytest
from model_reference import (
    coupled_residual,
    eq12_pressure_moment,
    resisting_moment,
    robot_contact_jacobian,
)
from scipy.integrate import quad
from valves_reference import (
    ATMOSPHERIC_PRESSURE,
    GAS_CONSTANT,
    LAMINAR_RATIO,
    REFERENCE_DENSITY,
    REFERENCE_TEMPERATURE,
    SPEC_PNEUMATICS,
    GloveChambers,
    RigidChambers,
    Supply,
    flow_function,
    integrate,
    mass_flow,
    robot_jacobian,
)

from exodigit_model import load_params

PARAMS = load_params()
EXACT = 1e-12
"""Relative agreement of two evaluations of the same formula (rounding only)."""
INTEGRATION_RTOL = 1e-7
"""Relative agreement of the reference integration with a closed form (its rtol is 1e-9)."""
VENT_TIME_ATOL = 1e-7
"""Agreement of a vent's time with the quadrature of 1/Q, s."""
JACOBIAN_ATOL = 1e-9
"""Agreement of the complex-step J_R* with model_reference's central differences, m."""
RESIDUAL_ATOL = 1e-10
"""Largest residual of eq 36 (adaptive quadrature, J_R* by central differences) accepted at a
reference pose, N·m."""
VOLUMES = (5e-6, 3e-6, 1.5e-6)
"""The rigid chambers, m³."""
CONDUCTANCE, CRITICAL_RATIO = 5e-10, 0.3
"""C, m³/(s Pa), and b of every valve in the rigid-chamber checks."""


def supply(pressure, temperature=REFERENCE_TEMPERATURE):
    chamber = {
        'inlet_conductance': CONDUCTANCE,
        'inlet_critical_ratio': CRITICAL_RATIO,
        'outlet_conductance': CONDUCTANCE,
        'outlet_critical_ratio': CRITICAL_RATIO,
        'dead_volume': 1e-6,
        'leak_conductance': 0.0,
    }
    return Supply(
        {'supply_pressure': pressure, 'temperature': temperature, 'chambers': [chamber] * 3}
    )


# -- the flow function (14.3) -------------------------------------------------------------------


@pytest.mark.parametrize('b', [0.0, 0.3, 0.528, 0.9])
def test_flow_function_is_continuous_where_its_pieces_meet(b):
    assert flow_function(b, b) == 1.0
    assert flow_function(b + 1e-9, b) == pytest.approx(1.0, abs=1e-12)
    below, above = LAMINAR_RATIO * (1 - 1e-13), LAMINAR_RATIO * (1 + 1e-13)
    assert flow_function(below, b) == pytest.approx(flow_function(above, b), rel=1e-9)
    assert flow_function(1.0, b) == 0.0
    elliptic = math.sqrt(1.0 - ((0.5 * (1 + b) - b) / (1 - b)) ** 2)  # r halfway between b and 1
    assert flow_function(0.5 * (1 + b), b) == pytest.approx(elliptic, rel=EXACT)


def test_mass_flow_is_choked_below_the_critical_ratio_and_odd_in_its_pressures():
    temperature = 330.0
    choked = CONDUCTANCE * REFERENCE_DENSITY * 5e5 * math.sqrt(REFERENCE_TEMPERATURE / temperature)
    q = mass_flow(5e5, 1e5, CONDUCTANCE, CRITICAL_RATIO, temperature)
    assert q == pytest.approx(choked, rel=EXACT)
    assert mass_flow(1e5, 5e5, CONDUCTANCE, CRITICAL_RATIO, temperature) == -q
    assert mass_flow(2e5, 2e5, CONDUCTANCE, CRITICAL_RATIO, temperature) == 0.0


# -- the integration against closed forms -------------------------------------------------------


def test_choked_fill_of_a_rigid_chamber_is_linear_in_time():
    """Choked (P ≤ b·P_s), (14.4) is dm/dt = u·C·ρ0·P_s: P = P_atm + u·C·ρ0·P_s·R·T/V·t."""
    source = supply(500e3)
    chambers = RigidChambers(source, VOLUMES)
    openings = np.array([1.0, 0.5, 0.25, 0.0, 0.0, 0.0])
    start = source.mass_of(np.full(3, ATMOSPHERIC_PRESSURE), VOLUMES)
    run = integrate(chambers, np.tile(openings, (5, 1)), 0.002, start)
    absolute = run.pressure + ATMOSPHERIC_PRESSURE
    assert absolute.max() < CRITICAL_RATIO * source.supply  # still choked at the end
    slope = openings[:3] * CONDUCTANCE * REFERENCE_DENSITY * source.supply
    expected = ATMOSPHERIC_PRESSURE + np.outer(run.t, slope * GAS_CONSTANT * 293.15 / VOLUMES)
    np.testing.assert_allclose(absolute, expected, rtol=INTEGRATION_RTOL)


@pytest.mark.parametrize('start', [100e3, 500e3])
def test_vent_of_a_rigid_chamber_takes_the_time_a_quadrature_of_its_flow_gives(start):
    """t(P) = ∫_P^{P_0} V/(R·T·u·Q(x, P_atm)) dx; from 500 kPa the vent starts choked, and every
    vent ends in the laminar region (the quadrature breaks at P_atm/0.999)."""
    source = supply(0.0)
    chambers = RigidChambers(source, VOLUMES)
    openings = np.array([0.0, 0.0, 0.0, 1.0, 0.5, 0.2])
    initial = np.full(3, start + ATMOSPHERIC_PRESSURE)
    run = integrate(chambers, np.tile(openings, (30, 1)), 0.01, source.mass_of(initial, VOLUMES))
    laminar = ATMOSPHERIC_PRESSURE / LAMINAR_RATIO
    reached = 0
    for i in range(3):

        def seconds_per_pascal(x, i=i):
            flow = mass_flow(x, ATMOSPHERIC_PRESSURE, CONDUCTANCE, CRITICAL_RATIO, 293.15)
            return VOLUMES[i] / (GAS_CONSTANT * 293.15 * openings[3 + i] * flow)

        for t, gauge in zip(run.t[1:], run.pressure[1:, i], strict=True):
            pressure = gauge + ATMOSPHERIC_PRESSURE
            if gauge < 1.0:  # the tail: the time of the last pascal is ill-conditioned
                break
            points = [laminar] if pressure < laminar < initial[i] else None
            elapsed, _ = quad(
                seconds_per_pascal, pressure, initial[i], points=points, epsabs=0, epsrel=1e-12
            )
            assert elapsed == pytest.approx(t, abs=VENT_TIME_ATOL)
            reached = max(reached, pressure < laminar)
    assert reached  # some chamber reached the laminar region


def test_a_closed_chamber_keeps_its_air():
    source = supply(100e3)
    start = source.mass_of(np.full(3, 150e3), VOLUMES)
    run = integrate(RigidChambers(source, VOLUMES), np.zeros((3, 6)), 0.01, start)
    np.testing.assert_array_equal(run.mass, np.tile(start, (4, 1)))


# -- the statics and the volume -----------------------------------------------------------------


@pytest.mark.parametrize('angle', [0.0, 0.05, 0.7, 1.4])
def test_fast_moment_equals_adaptive_quadrature(angle):
    chambers = GloveChambers(PARAMS, Supply(SPEC_PNEUMATICS))
    for segment in PARAMS.exo_digit.segments:
        expected = resisting_moment(PARAMS.material, segment, angle)
        fast = chambers.moment(PARAMS.material, segment, angle)
        assert fast == pytest.approx(expected, rel=EXACT, abs=1e-300)


def test_robot_jacobian_equals_differences_of_the_printed_kinematics_and_is_finite_at_zero():
    for q in ([0.3, 0.5, 0.4], [1.2, 0.1, 1.0], [-0.2, 0.05, 0.8]):
        np.testing.assert_allclose(
            robot_jacobian(PARAMS, np.array(q)),
            robot_contact_jacobian(PARAMS, np.array(q)),
            rtol=0,
            atol=JACOBIAN_ATOL,
        )
    tiny = robot_contact_jacobian(PARAMS, np.full(3, 1e-4))
    np.testing.assert_allclose(robot_jacobian(PARAMS, np.zeros(3)), tiny, rtol=0, atol=1e-5)


def test_pose_solves_the_statics_the_gas_law_and_the_volume_of_14_1():
    chambers = GloveChambers(PARAMS, Supply(SPEC_PNEUMATICS))
    pressures, volumes, q = chambers.pose(chambers.rest_mass)
    np.testing.assert_allclose(pressures, ATMOSPHERIC_PRESSURE, rtol=EXACT)
    np.testing.assert_allclose(q, 0.0, atol=1e-12)
    for scale in (1.3, 1.9):
        mass = chambers.rest_mass * np.array([scale, 1.0 + 0.5 * (scale - 1), scale])
        pressures, volumes, q = chambers.pose(mass)
        gauge = pressures - ATMOSPHERIC_PRESSURE
        assert np.abs(coupled_residual(PARAMS, q, gauge)).max() < RESIDUAL_ATOL
        np.testing.assert_allclose(pressures * volumes, mass * GAS_CONSTANT * 293.15, rtol=EXACT)
        for i, segment in enumerate(PARAMS.exo_digit.segments):
            r0, h = segment.inner_radius, segment.wall_height
            cavity = (2 * r0 * h + 0.5 * math.pi * r0 * r0) * segment.arc_length
            expected = 1e-6 + cavity + eq12_pressure_moment(segment) * q[i]
            assert volumes[i] == pytest.approx(expected, rel=EXACT)
