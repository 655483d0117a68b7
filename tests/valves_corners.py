"""The box of valves, tubing and supplies of issue 35 and scenarios to step its corners through.

Shared by tests/test_model_valves_corners.py and benchmarks/bench_valves_corners.py. The box is
typed in from the issue and docs/valves.md ("Where the bound holds"), not read from the model:
conductance C 1e-10..2e-9 m³/(s·Pa) (inlet and outlet alike), critical ratio b 0.05..0.6,
dead volume 0.1..5 cm³, supply 30..200 kPa gauge, leak 0..1e-11 kg/(s·Pa); on the default
glove and on the extensible glove of docs/extensible (its MCP layer E_L = 0, the fitted softer
material). The reference is tests/valves_reference.py: :class:`GloveChambers` (statics written
from the contract) for the default glove, :class:`SolvedChambers` (the model's statics, the air
written from the contract) for the extensible one.
"""

import itertools
from functools import cache
from pathlib import Path

import numpy as np
from valves_reference import GloveChambers, SolvedChambers, Supply, integrate

from exodigit_model import (
    GloveModel,
    GloveSimulation,
    SimulationSettings,
    load_params,
    params_from_dict,
)

ROOT = Path(__file__).resolve().parents[1]
BOX = {
    'conductance': (1e-10, 2e-9),
    'critical_ratio': (0.05, 0.6),
    'dead_volume': (1e-7, 5e-6),
    'supply_pressure': (30e3, 200e3),
    'leak_conductance': (0.0, 1e-11),
}
"""Low and high end of each quantity of the box (SI; supply gauge)."""
CORNERS = tuple(itertools.product(*BOX.values()))
"""The 32 corners: (C, b, V_d, p_s, G)."""
GLOVES = {
    'default': (),
    'extensible': (ROOT / 'docs' / 'extensible' / 'fig12_calibrated.yaml',),
}
"""Parameter files of each glove, merged over the defaults."""
TEMPERATURE = 293.15
"""T of the air, K (the default)."""


def hold(openings, steps):
    return np.tile(np.asarray(openings, dtype=float), (steps, 1))


SCENARIO = np.vstack(
    [
        hold([1, 1, 1, 0, 0, 0], 4),
        hold([0] * 6, 1),
        hold([0, 0, 0, 1, 1, 1], 4),
        hold([0.7, 0.4, 0.2, 0.0, 0.1, 0.0], 3),
        hold([0.3, 0.2, 0.1, 0.5, 0.3, 0.8], 3),
    ]
)
"""Openings per 20 ms (u_in MCP, PIP, DIP, then u_out): fill choked (from rest the inlet
chokes whenever b·P_s ≥ P), hold, vent, partial openings with outlets bleeding, then
partial vents against partly open inlets; 0.3 s. At 100 Hz each is held over two steps, at
50 Hz one. Every chamber fills and vents with the others: one chamber at 200 kPa beside
vented ones drives the extensible glove's MCP far past its range of motion, where its
statics stop converging (docs/valves.md, "Where the bound holds")."""
PERIOD = 0.02
"""How long each row of :data:`SCENARIO` is held, s."""
FINE_SCENARIO = np.vstack(
    [
        hold([1, 1, 1, 0, 0, 0], 6),
        hold([0] * 6, 2),
        hold([0, 0, 0, 1, 1, 1], 6),
        hold([0.6, 0.3, 0.15, 0.1, 0.0, 0.05], 3),
        hold([0, 0, 0, 0.4, 0.25, 0.7], 3),
    ]
)
"""Openings per 10 ms: the scenarios of issue 26 shortened, each row one step at 100 Hz."""
FINE_PERIOD = 0.01


def pneumatics(corner):
    """The ``pneumatics`` section (a dict) of a corner (C, b, V_d, p_s, G)."""
    conductance, critical, dead, supply, leak = corner
    chamber = {
        'inlet_conductance': conductance,
        'inlet_critical_ratio': critical,
        'outlet_conductance': conductance,
        'outlet_critical_ratio': critical,
        'dead_volume': dead,
        'leak_conductance': leak,
    }
    names = ('mcp', 'pip', 'dip')
    return {
        'supply_pressure': supply,
        'temperature': TEMPERATURE,
        'chambers': [dict(chamber, name=name) for name in names],
    }


def model(glove, corner):
    """The model of ``glove`` with the air of ``corner``."""
    data = load_params(GLOVES[glove]).to_dict()
    data['pneumatics'] = pneumatics(corner)
    return GloveModel(params_from_dict(data))


@cache
def reference(glove, corner, fine=False):
    """The reference trajectory of the (fine) scenario on its grid."""
    air = pneumatics(corner)
    glove_model = model(glove, corner)
    supply = Supply(air)
    if glove == 'default':
        chambers = GloveChambers(glove_model.params, supply)
    else:
        chambers = SolvedChambers(glove_model, supply)
    openings, period = (FINE_SCENARIO, FINE_PERIOD) if fine else (SCENARIO, PERIOD)
    return integrate(chambers, openings, period, chambers.rest_mass)


def simulated(glove, corner, rate, fine=False):
    """The model's gauge pressures at the scenario's grid points, stepped at ``rate`` Hz."""
    openings, period = (FINE_SCENARIO, FINE_PERIOD) if fine else (SCENARIO, PERIOD)
    repeat = round(rate * period)
    simulation = GloveSimulation(
        model(glove, corner), SimulationSettings(rate_hz=rate), actuation='valves'
    )
    state = simulation.run(np.repeat(openings, repeat, axis=0))
    return state.pressure[repeat - 1 :: repeat]


def pressure_error(glove, corner, rate, fine=False):
    """Largest |p − p_ref| over the grid points and chambers, Pa."""
    expected = reference(glove, corner, fine).pressure[1:]
    return float(np.abs(simulated(glove, corner, rate, fine) - expected).max())
