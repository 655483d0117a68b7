"""The valve mode converges to the DAE of docs/spec/model.md §14 (issue 26).

``GloveSimulation(..., actuation='valves')`` steps six openings (inlets MCP, PIP, DIP, then
outlets), each held over its step. Its chamber pressures are compared with
tests/valves_reference.py, an independent tight-tolerance integration of {(14.4), (14.2), eq 36}
that solves the statics at every evaluation, on scenarios of 10 ms openings (fill, hold, vent;
staggered; partial openings with bleeding outlets) on the default glove and finger:

- at 100 Hz every step's pressures lie within 0.5 kPa of the reference;
- at 100, 200 and 400 Hz (each 10 ms opening held over 1, 2 or 4 steps) the largest error on the
  10 ms grid falls by 2^order per halving, ``order`` being what the stepping scheme states
  (``STATED_ORDER``), less ``ORDER_SLACK``;
- the state obeys the gas law (14.2) and the volume (14.1) of its own angles, starts at the
  vented mass, and clips openings outside [0, 1], saying so.

The defaults themselves are checked against the document by tests/test_model_params.py
(``SPEC_DEFAULTS['pneumatics']`` of tests/model_reference.py, which the reference uses too).

Run with ``-s`` to see the figures.
"""

import itertools
import math
from functools import cache

import numpy as np
import pytest
from model_reference import eq12_pressure_moment
from valves_reference import (
    ATMOSPHERIC_PRESSURE,
    GAS_CONSTANT,
    SPEC_PNEUMATICS,
    GloveChambers,
    Supply,
    integrate,
)

from exodigit_model import GloveModel, GloveSimulation, SimulationSettings, load_params

PARAMS = load_params()
MODEL = GloveModel(PARAMS)
PERIOD = 0.01
"""Δt of the scenarios' openings, s (100 Hz)."""
RATES = (100.0, 200.0, 400.0)
"""Step rates of the order check, Hz: each halves the step."""
PRESSURE_ATOL = 500.0
"""Largest pressure error at 100 Hz against the reference, Pa (the contract's 0.5 kPa)."""
STATED_ORDER = 2.0
"""The order of the stepping scheme as its implementer states it (docs/spec/model.md §14,
"Stepping scheme": ROS2 sub-steps along a predicted volume path, second order)."""
ORDER_SLACK = 0.25
"""The measured order may fall this far below the stated one (second order: ≥ 1.75 per
halving). A step that fills or vents fast splits into a whole number of shorter steps
(docs/valves.md, "Where the bound holds"), a number that changes where a chamber's rate crosses
a multiple of the split rate, so one halving may gain a little less than 2² (fill-hold-vent:
1.79 from 100 to 200 Hz, 2.27 from 200 to 400 Hz)."""
EXACT = 1e-9
"""Relative agreement of the state with (14.1) and (14.2) evaluated from the state itself."""
TEMPERATURE = 293.15
"""T of the default pneumatics, K."""


def hold(openings, steps):
    return np.tile(np.asarray(openings, dtype=float), (steps, 1))


SCENARIOS = {
    'fill-hold-vent': np.vstack(
        [hold([1, 1, 1, 0, 0, 0], 12), hold([0] * 6, 6), hold([0, 0, 0, 1, 1, 1], 12)]
    ),
    'staggered': np.vstack(
        [
            hold([1, 0, 0, 0, 0, 0], 5),
            hold([1, 1, 0, 0, 0, 0], 5),
            hold([0, 1, 1, 0, 0, 0], 5),
            hold([0, 0, 1, 1, 0, 0], 5),
            hold([0, 0, 0, 0, 1, 1], 5),
        ]
    ),
    'partial': np.vstack(
        [hold([0.6, 0.3, 0.15, 0.1, 0.0, 0.05], 15), hold([0, 0, 0, 0.4, 0.25, 0.7], 10)]
    ),
}
"""Openings per 10 ms: u_in (MCP, PIP, DIP), then u_out."""


@cache
def reference(name):
    """The reference trajectory of scenario ``name`` on the 10 ms grid."""
    pneumatics = dict(SPEC_PNEUMATICS, supply_pressure=SimulationSettings().max_supply_pressure)
    chambers = GloveChambers(PARAMS, Supply(pneumatics))
    return integrate(chambers, SCENARIOS[name], PERIOD, chambers.rest_mass)


@cache
def simulated(name, rate):
    """(initial state, the states at the 10 ms grid points) of the valve mode at ``rate``."""
    repeat = round(rate * PERIOD)
    simulation = GloveSimulation(MODEL, SimulationSettings(rate_hz=rate), actuation='valves')
    start = simulation.state
    states = []
    for openings in SCENARIOS[name]:
        for _ in range(repeat):
            state = simulation.step(openings)
        states.append(state)
    return start, states


def pressure_error(name, rate):
    """Largest |p − p_ref| over the grid points and chambers, Pa."""
    pressures = np.array([state.pressure for state in simulated(name, rate)[1]])
    return np.abs(pressures - reference(name).pressure[1:]).max()


@pytest.mark.parametrize('name', SCENARIOS)
def test_pressures_at_100_hz_lie_within_half_a_kilopascal_of_the_reference(name):
    start, states = simulated(name, 100.0)
    expected = reference(name)
    np.testing.assert_allclose(start.pressure, 0.0, atol=1e-9)
    np.testing.assert_allclose(start.mass, expected.mass[0], rtol=EXACT)
    errors = np.abs(np.array([state.pressure for state in states]) - expected.pressure[1:])
    print(f'\n{name}: at 100 Hz the largest error is {errors.max():.1f} Pa', end='')
    assert errors.max() < PRESSURE_ATOL
    assert expected.pressure.max() > 50e3  # the scenario fills


@pytest.mark.parametrize('name', SCENARIOS)
def test_the_error_falls_with_the_stated_order_when_the_step_halves(name):
    errors = [pressure_error(name, rate) for rate in RATES]
    orders = [math.log2(coarse / fine) for coarse, fine in itertools.pairwise(errors)]
    figures = ', '.join(
        f'{rate:.0f} Hz {error:.2f} Pa' for rate, error in zip(RATES, errors, strict=True)
    )
    print(f'\n{name}: {figures}; orders {", ".join(f"{o:.2f}" for o in orders)}', end='')
    assert min(orders) >= STATED_ORDER - ORDER_SLACK


@pytest.mark.parametrize('name', SCENARIOS)
def test_the_state_obeys_the_gas_law_and_the_chamber_volume(name):
    """(14.2) P·V = m·R·T and (14.1) V = V_d + A_c·ℓ + r_pA_p·q from the state's own q, ℓ."""
    cavities = np.array(
        [
            2 * s.inner_radius * s.wall_height + 0.5 * math.pi * s.inner_radius**2
            for s in PARAMS.exo_digit.segments
        ]
    )
    moments = np.array([eq12_pressure_moment(s) for s in PARAMS.exo_digit.segments])
    dead = np.array([chamber['dead_volume'] for chamber in SPEC_PNEUMATICS['chambers']])
    for state in simulated(name, 100.0)[1]:
        absolute = state.pressure + ATMOSPHERIC_PRESSURE
        np.testing.assert_allclose(
            absolute * state.volume, state.mass * GAS_CONSTANT * TEMPERATURE, rtol=EXACT
        )
        expected = dead + cavities * state.lengths + moments * state.q
        np.testing.assert_allclose(state.volume, expected, rtol=EXACT)


def test_openings_outside_the_unit_interval_are_clipped_and_reported():
    settings = SimulationSettings()
    clipped = GloveSimulation(MODEL, settings, actuation='valves')
    inside = GloveSimulation(MODEL, settings, actuation='valves')
    state = clipped.step([1.5, 0.5, -0.2, 0.0, 2.0, 0.3])
    expected = inside.step([1.0, 0.5, 0.0, 0.0, 1.0, 0.3])
    assert state.saturated and not expected.saturated
    np.testing.assert_array_equal(state.command, [1.0, 0.5, 0.0, 0.0, 1.0, 0.3])
    np.testing.assert_array_equal(state.pressure, expected.pressure)
