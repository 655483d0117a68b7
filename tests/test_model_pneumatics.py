"""The chambers behind valves (docs/spec/model.md §14), each against an independent answer.

(a) a fixed volume filled through a choked inlet: the closed form of a constant mass flow;
(b) a fixed volume vented: the time scipy's ``quad`` gives for dt = −V/(R·T)·dP/Q(P, P_atm),
    and the error's order;
(c) both valves closed, no leak: the air mass stays, and P·V with it, while the finger moves;
(d) p·∂V/∂q = τ_p and ∂V/∂ℓ = A_c, by finite differences and by quadrature of the cavity;
(e) ψ continuous where its pieces meet, Q antisymmetric and equal to ISO 6358-3 written out here;
(f) regulator mode: pressures from the zero-order hold of §13, bit for bit, and angles those of
    ``GloveModel.solve`` at those pressures (the stepper's other half, independent of it);
and the ``pneumatics`` parameters (their checks name the key), reset and the command's checks.
"""

import math
import warnings

import numpy as np
import pytest
from exodigit_model.kernels.valves import AIR_VOLUME, advance_masses
from exodigit_model.physics.pneumatics import (
    ATMOSPHERIC_PRESSURE,
    GAS_CONSTANT,
    REFERENCE_DENSITY,
    REFERENCE_TEMPERATURE,
    air_constants,
    cavity_area,
    chamber_volume,
    flow_function,
    mass_flow,
    rest_masses,
)
from scipy.integrate import quad

from exodigit_model import (
    GloveModel,
    GloveSimulation,
    OutsideModelWarning,
    ParameterError,
    SimulationSettings,
    dump_params,
    load_params,
    params_from_dict,
)

#: Relative tolerance of results that are exact up to rounding.
ROUND_OFF = 1e-12
#: Relative tolerance of an integration at 100 Hz against quadrature.
INTEGRATION = 1e-2
#: Joint angles' tolerance against a separate solve, rad (the solver's is 1e-12 relative).
SOLVER = 1e-9
#: The air's temperature of the defaults, K, and R·T, J/kg.
T = 293.15
RT = GAS_CONSTANT * T


def iso_flow(conductance, critical, upstream, downstream, temperature):
    """ISO 6358-3 (docs/spec/model.md (14.3)) written out: Q(P_u, P_d), kg/s, P_u >= P_d."""
    r = downstream / upstream
    if r <= critical:
        psi = 1.0
    elif r <= 0.999:
        psi = math.sqrt(1.0 - ((r - critical) / (1.0 - critical)) ** 2)
    else:
        psi = math.sqrt(1.0 - ((0.999 - critical) / (1.0 - critical)) ** 2) * (1 - r) / 0.001
    density = REFERENCE_DENSITY * math.sqrt(REFERENCE_TEMPERATURE / temperature)
    return conductance * density * upstream * psi


def chamber_rows(critical=0.3, supply=300e3, leak=0.0):
    """Pneumatic constants of the default glove with these valves' b, supply (Pa) and leak."""
    row = {'inlet_critical_ratio': critical, 'outlet_critical_ratio': critical}
    row['leak_conductance'] = leak
    model = GloveModel(params_from_dict({'pneumatics': {'chambers': [row, row, row]}}))
    with warnings.catch_warnings():  # 300 kPa on purpose, to choke: outside the checked box
        warnings.simplefilter('ignore', OutsideModelWarning)
        return air_constants(model, supply)


def fixed_volume(rows, pressure, openings, period, steps):
    """Absolute pressures (steps + 1, 3) of the chambers at their rest volumes, from
    ``pressure`` (Pa absolute), stepped by :func:`advance_masses` with fixed volumes."""
    volume = rows[:, AIR_VOLUME].copy()  # contiguous, as the simulation's: no second compile
    mass = np.full(3, pressure) * volume / RT
    history = [mass]
    for _ in range(steps):
        mass = advance_masses(rows, mass, volume, volume, np.asarray(openings, float), period)
        history.append(mass)
    return np.array(history) * RT / volume


# -- (a) choked filling --------------------------------------------------------------------


def test_a_fixed_volume_fills_through_a_choked_inlet_linearly():
    supply, critical, period = 300e3, 0.45, 1e-3
    rows = chamber_rows(critical, supply)
    absolute_supply = supply + ATMOSPHERIC_PRESSURE
    pressure = fixed_volume(rows, ATMOSPHERIC_PRESSURE, [1, 1, 1, 0, 0, 0], period, 10)
    assert np.all(pressure[-1] <= critical * absolute_supply)  # choked all along
    volume = rows[:, AIR_VOLUME]
    slope = RT * 5e-10 * REFERENCE_DENSITY * absolute_supply / volume  # Pa/s, closed form
    t = period * np.arange(11)[:, None]
    expected = ATMOSPHERIC_PRESSURE + slope * t
    np.testing.assert_allclose(pressure, expected, rtol=ROUND_OFF)
    assert pressure[-1, 2] - pressure[0, 2] > 10e3  # it did fill


# -- (b) venting ---------------------------------------------------------------------------


def venting_error(period: float, duration: float = 0.04) -> np.ndarray:
    """Per chamber, the relative error of the venting time: ``duration`` against the time of
    ``quad`` from the start to the pressure the steps of ``period`` reached."""
    rows, start = chamber_rows(), 250e3
    pressure = fixed_volume(rows, start, [0, 0, 0, 1, 1, 1], period, round(duration / period))
    volume, errors = rows[:, AIR_VOLUME], []
    for k in range(3):
        end = pressure[-1, k]
        assert 1.05 * ATMOSPHERIC_PRESSURE < end < 0.8 * start  # vented, far from the end

        def rate(p, k=k):
            return volume[k] / RT / iso_flow(5e-10, 0.3, p, ATMOSPHERIC_PRESSURE, T)

        time, _ = quad(rate, end, start, epsabs=0.0, epsrel=1e-12, limit=200)
        errors.append(abs(time / duration - 1.0))
    return np.array(errors)


def test_venting_a_fixed_volume_takes_the_time_quadrature_gives_to_second_order():
    # ROS2 is second order in its sub-step h, and h = Δt/round(T_sub/Δt) ≈ Δt²/T_sub falls
    # four-fold when the step halves (kernels/valves.py): the error sixteen-fold, more than
    # twelve (an order in h of 1.8 at least).
    coarse, fine = venting_error(0.01), venting_error(0.005)
    assert np.all(coarse < INTEGRATION)
    assert np.all(coarse / fine > 12.0)


# -- (c) closed valves ---------------------------------------------------------------------


def test_closed_valves_keep_the_air_while_the_patient_moves_the_finger():
    simulation = GloveSimulation(actuation='valves')
    for _ in range(5):
        filled = simulation.step([1.0, 0.6, 0.3, 0.0, 0.0, 0.0])
    closed = np.zeros(6)
    t = np.arange(40) * 0.01
    pushes = 0.05 * np.sin(2 * np.pi * 2 * t)[:, None] * np.array([1.0, -0.5, 0.8])
    run = simulation.run(np.tile(closed, (40, 1)), pushes)
    assert np.all(run.converged)
    assert np.ptp(run.q[:, 0]) > 0.05  # the patient moves the finger
    np.testing.assert_array_equal(run.mass, np.tile(filled.mass, (40, 1)))
    pv = (run.pressure + ATMOSPHERIC_PRESSURE) * run.volume
    np.testing.assert_allclose(pv, np.tile(filled.mass * RT, (40, 1)), rtol=ROUND_OFF)
    assert np.ptp(run.pressure[:, 0]) > 100.0  # and the gas spring answers


# -- (d) the volume's slopes ---------------------------------------------------------------


def test_pressure_times_the_volumes_slope_is_the_pressure_torque():
    model, q, p, h = GloveModel(), np.array([0.4, 0.7, 0.2]), np.array([30e3, 50e3, 70e3]), 1e-4
    lengths = model.constants.arc_lengths
    slope = (chamber_volume(model, q + h, lengths) - chamber_volume(model, q - h, lengths)) / (
        2 * h
    )
    np.testing.assert_allclose(p * slope, model.pressure_torque(p), rtol=1e-9)


def test_the_volume_grows_along_the_segment_by_the_cavitys_cross_section():
    model, q = GloveModel(), np.array([0.4, 0.7, 0.2])
    lengths, h = model.constants.arc_lengths, 1e-5
    slope = (chamber_volume(model, q, lengths + h) - chamber_volume(model, q, lengths - h)) / (
        2 * h
    )
    for segment, value in zip(model.params.exo_digit.segments, slope, strict=True):
        r0, wall = segment.inner_radius, segment.wall_height

        def width(angle, r0=r0):  # the half circle's width at y = wall + r0·sin(angle), dy
            return 2 * r0 * math.cos(angle) * r0 * math.cos(angle)

        arch, _ = quad(width, 0.0, 0.5 * math.pi, epsrel=1e-13)
        area = 2 * r0 * wall + arch  # under the arch: the rectangle between the walls
        assert cavity_area(segment) == pytest.approx(area, rel=1e-9)
        assert value == pytest.approx(area, rel=1e-9)


# -- (e) the flow function -----------------------------------------------------------------


@pytest.mark.parametrize('critical', [0.0, 0.3, 0.528, 0.9])
def test_psi_is_continuous_where_its_pieces_meet(critical):
    for joint in (critical, 0.999):
        below, above = (
            flow_function(joint - 1e-12, critical),
            flow_function(joint + 1e-12, critical),
        )
        assert above == pytest.approx(below, abs=1e-5)
    assert flow_function(1.0, critical) == 0.0
    assert flow_function(critical, critical) == 1.0


@pytest.mark.parametrize('temperature', [293.15, 330.0])
def test_q_is_iso_6358_and_antisymmetric(temperature):
    for upstream, downstream in [(5e5, 1e5), (2e5, 1.5e5), (1.0001e5, 1e5), (3e5, 2.999e5)]:
        forward = mass_flow(5e-10, 0.3, upstream, downstream, temperature)
        expected = iso_flow(5e-10, 0.3, upstream, downstream, temperature)
        assert forward == pytest.approx(expected, rel=ROUND_OFF)
        assert mass_flow(5e-10, 0.3, downstream, upstream, temperature) == -forward
    assert mass_flow(5e-10, 0.3, 2e5, 2e5, temperature) == 0.0


# -- (f) regulator mode --------------------------------------------------------------------


def test_regulator_pressures_follow_the_zero_order_hold_and_the_statics():
    settings = SimulationSettings(pressure_time_constant=0.03)
    model, simulation = GloveModel(), GloveSimulation(settings=settings)
    decay = math.exp(-settings.period / settings.pressure_time_constant)
    t = np.arange(60) * settings.period
    commands = 60e3 + 70e3 * np.sin(2 * np.pi * 2 * t)[:, None] * np.array([1.0, 0.7, -0.5])
    pressure, q = np.zeros(3), np.zeros(3)
    for command in commands:
        state = simulation.step(command)
        held = np.clip(command, 0.0, settings.max_supply_pressure)
        pressure = held + (pressure - held) * decay  # §13, step 1
        assert state.pressure.tobytes() == pressure.tobytes()
        solution = model.solve(pressure, q)
        np.testing.assert_allclose(state.q, solution.q, rtol=0.0, atol=SOLVER)
        q = solution.q
    assert state.mass is None and state.volume is None


# -- parameters, reset and commands ----------------------------------------------------------


def test_the_pneumatics_section_round_trips_and_names_a_bad_key(tmp_path):
    params = params_from_dict({'pneumatics': {'supply_pressure': 250e3, 'temperature': 300.0}})
    dump_params(params, tmp_path / 'glove.yaml')
    assert load_params(tmp_path / 'glove.yaml') == params
    for data, key in [
        (
            {'chambers': [{}, {'dead_volume': -1e-6}, {}]},
            r'pneumatics\.chambers\[1\]\.dead_volume',
        ),
        ({'chambers': [{'inlet_critical_ratio': 1.0}, {}, {}]}, r'chambers\[0\]\.inlet_critical'),
        ({'temperature': 0.0}, r'pneumatics\.temperature'),
        ({'supply_pressure': -1.0}, r'pneumatics\.supply_pressure'),
        ({'chambers': [{}, {}]}, r'pneumatics\.chambers has 2 entries'),
        ({'chambers': [{'outlet_conductance': 'x'}, {}, {}]}, r'outlet_conductance'),
    ]:
        with pytest.raises(ParameterError, match=key):
            params_from_dict({'pneumatics': data})


def test_reset_vents_the_chambers_to_the_rest_masses():
    simulation = GloveSimulation(count=2, actuation='valves')
    rest = simulation.state
    np.testing.assert_allclose(
        rest.mass, rest_masses(rest.volume, T), rtol=ROUND_OFF
    )  # P_atm·V/(R·T)
    for _ in range(10):
        simulation.step(np.tile([1.0, 1.0, 1.0, 0.0, 0.0, 0.0], (2, 1)))
    assert np.all(simulation.state.pressure > 10e3)
    vented = simulation.reset()
    for field in ('mass', 'volume', 'q', 'pressure'):
        np.testing.assert_array_equal(getattr(vented, field), getattr(rest, field))
    assert np.all(vented.pressure == 0.0) and vented.command.shape == (2, 6)


def test_the_supply_is_the_max_supply_pressure_unless_the_parameters_give_one():
    openings = [1.0, 1.0, 1.0, 0.0, 0.0, 0.0]
    settings = SimulationSettings(max_supply_pressure=60e3)
    simulation = GloveSimulation(settings=settings, actuation='valves')
    for _ in range(60):
        state = simulation.step(openings)
    np.testing.assert_allclose(state.pressure, 60e3, rtol=1e-6)
    model = GloveModel(params_from_dict({'pneumatics': {'supply_pressure': 40e3}}))
    simulation = GloveSimulation(model, settings, actuation='valves')
    for _ in range(60):
        state = simulation.step(openings)
    np.testing.assert_allclose(state.pressure, 40e3, rtol=1e-6)


def test_openings_are_clipped_and_reported_bad_commands_refused():
    simulation = GloveSimulation(actuation='valves')
    state = simulation.step([1.5, -0.2, 0.5, 0.0, 0.0, 0.0])
    np.testing.assert_array_equal(state.command, [1.0, 0.0, 0.5, 0.0, 0.0, 0.0])
    assert state.saturated and simulation.chambers.saturation.below_zero == 1
    for bad in ([0.0] * 3, [0.0] * 7, [np.nan] + [0.0] * 5, 'abc'):
        with pytest.raises(ValueError, match='command'):
            simulation.step(bad)
    with pytest.raises(ValueError, match='actuation'):
        GloveSimulation(actuation='pistons')
