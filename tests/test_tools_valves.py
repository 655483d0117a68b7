"""``exodigit valves`` (issue 26, item 4): the figure's data against independent answers.

The regulator glove's pressures against the closed form of the zero-order-held first-order lag
(docs/spec/model.md §13); both gloves' angles against separate statics solves
(``GloveModel.solve``) at their pressures; the valve glove's pressures within the loop's deadband
of each stair by its end; its supply air against the air masses' rise (the stairs rise, so no
air leaves). No number is copied from the implementation.
"""

import math

import numpy as np
from exodigit_model.physics.pneumatics import ATMOSPHERIC_PRESSURE, GAS_CONSTANT
from exodigit_model.tools import valves
from exodigit_model.tools.cli import main

from exodigit_model import GloveModel, SimulationSettings

MODEL = GloveModel()
SETTINGS = SimulationSettings()
STEPS = 450
"""4.5 s: the stairs 0, 10 and 20 kPa of the staircase mode (2 s each)."""
SOLVER = 1e-9
"""Joint angles' tolerance against a separate solve, rad."""
ROUND_OFF = 1e-9
"""Relative tolerance of sums that are exact up to rounding."""
RT = GAS_CONSTANT * 293.15
"""R·T of the defaults' isothermal air, J/kg."""


def test_the_figures_data_are_the_lag_the_statics_and_the_loop():
    targets = valves.staircase_targets(STEPS, SETTINGS)
    assert targets[199].tolist() == [0.0] * 3 and targets[200].tolist() == [10e3] * 3
    c = valves.compare(MODEL, targets, SETTINGS)
    decay = math.exp(-SETTINGS.period / SETTINGS.pressure_time_constant)
    for end, level, previous, start in ((399, 10e3, 0.0, 200), (449, 20e3, 10e3, 400)):
        lag = level + (previous - level) * decay ** (end - start + 1)
        np.testing.assert_allclose(c.regulator_pressure[end], lag, rtol=1e-9)
        assert np.all(np.abs(c.valve_pressure[end] - level) <= 300.0 + 1e-6)
        for pressure, q in ((c.regulator_pressure, c.regulator_q), (c.valve_pressure, c.valve_q)):
            np.testing.assert_allclose(q[end], MODEL.solve(pressure[end]).q, atol=SOLVER)
    # the gas law (14.2) at the last step, and the air from the supply: the masses' rise from
    # the vented rest (P_atm in the rest volume), no air having left on a rising staircase
    absolute = c.valve_pressure[-1] + ATMOSPHERIC_PRESSURE
    np.testing.assert_allclose(c.mass[-1], absolute * c.volume[-1] / RT, rtol=ROUND_OFF)
    rest = ATMOSPHERIC_PRESSURE * c.volume[0] / RT
    np.testing.assert_allclose(c.inflow, c.mass[-1] - rest, rtol=ROUND_OFF)
    assert np.all(c.openings[:200, 3:] == 1.0) and not c.openings[200:, 3:].any()


def test_the_command_writes_the_figure_and_prints_a_line_per_joint(capsys, tmp_path):
    assert main(['valves', '--duration', '2.5', '--out', str(tmp_path / 'v.png')]) == 0
    out = capsys.readouterr().out.splitlines()
    assert [line.split(':')[0] for line in out[:3]] == ['MCP', 'PIP', 'DIP']
    assert (tmp_path / 'v.png').stat().st_size > 10_000
