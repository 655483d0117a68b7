"""The valve mode holds its bound over the box of issue 35 (docs/valves.md, the bound's box).

At corners of the box of tests/valves_corners.py (conductance, critical ratio, dead volume,
supply, leak; on the default and the extensible glove) the model's pressures are compared with
the tight-tolerance reference of tests/valves_reference.py on 20 ms openings (fill, hold, vent,
partial openings) stepped at 50, 100 and 200 Hz:

- at every rate every pressure lies within 0.5 kPa of the reference;
- at the fastest corners the largest error falls each time the step halves, and from 50 to
  200 Hz by at least 2^(2·``MEAN_ORDER``) (at the slow ones it is the reference's own).

The shortened run (the default) takes, on both gloves, the four corners where the chambers are
fastest (largest conductance, smallest dead volume; both critical ratios and both supplies)
and the slowest one; ``EXODIGIT_AIR_CORNERS=all`` runs all 32 on both (about ten minutes;
benchmarks/bench_valves_corners.py --errors prints every figure). Run with ``-s`` to see them.
"""

import itertools
import math
import os
import warnings
from functools import cache

import pytest
from valves_corners import BOX, CORNERS, GLOVES, model, pneumatics, pressure_error

from exodigit_model import (
    GloveModel,
    GloveSimulation,
    OutsideModelWarning,
    SimulationSettings,
    load_params,
    params_from_dict,
)

PRESSURE_ATOL = 500.0
"""Largest pressure error against the reference, Pa (docs/spec/model.md §14)."""
RATES = (50.0, 100.0, 200.0)
MEAN_ORDER = 0.8
"""From 50 to 200 Hz the largest error falls at least by 2^(2·MEAN_ORDER). The scheme is of
order two as the step shrinks (tests/test_model_valves_convergence.py, 100-400 Hz); at the
fastest corners 50-200 Hz is not yet that range: measured over all 64 corners and gloves the
mean order from 50 to 200 Hz is 0.98 or more (docs/valves.md)."""
RESOLVED = 2.0
"""Errors below this (Pa) are not used for an order: the reference's tolerance (relative 1e-9 of
the masses, the pose solved to 1e-12 rad) and the solver's (section 7) leave about 0.1 Pa."""

_high, _low = BOX['conductance'][1], BOX['dead_volume'][0]
FASTEST = [
    (_high, critical, _low, supply, leak)
    for (critical, supply), leak in zip(
        itertools.product(BOX['critical_ratio'], BOX['supply_pressure']),
        itertools.cycle(BOX['leak_conductance']),
    )
]
"""Largest valves on the smallest dead volume, both b and both supplies, the leak alternating."""
SLOWEST = (BOX['conductance'][0], BOX['critical_ratio'][1], BOX['dead_volume'][1], 30e3, 1e-11)
CHOSEN = CORNERS if os.environ.get('EXODIGIT_AIR_CORNERS') == 'all' else (*FASTEST, SLOWEST)


def label(corner):
    conductance, critical, dead, supply, leak = corner
    return f'C{conductance:.0e}-b{critical:g}-Vd{dead * 1e6:g}ml-ps{supply / 1e3:g}kPa-G{leak:.0e}'


@cache
def errors(glove, corner):
    """The largest pressure error at each of :data:`RATES`, Pa."""
    found = tuple(pressure_error(glove, corner, rate) for rate in RATES)
    shown = ' / '.join(f'{e:.1f}' for e in found)
    print(f'\n{glove} {label(corner)}: {shown} Pa at 50 / 100 / 200 Hz', end='')
    return found


@pytest.mark.slow
@pytest.mark.parametrize('glove', GLOVES)
@pytest.mark.parametrize('corner', CHOSEN, ids=label)
def test_pressures_lie_within_half_a_kilopascal_of_the_reference(glove, corner):
    assert max(errors(glove, corner)) < PRESSURE_ATOL


@pytest.mark.slow
@pytest.mark.parametrize('glove', GLOVES)
@pytest.mark.parametrize('corner', FASTEST, ids=label)
def test_the_error_falls_with_the_step(glove, corner):
    found = errors(glove, corner)
    assert found[0] > RESOLVED  # the corner moves the model away from the reference at all
    for coarse, fine in itertools.pairwise(found):
        assert fine < coarse
    if found[-1] > RESOLVED:
        assert math.log2(found[0] / found[-1]) >= 2.0 * MEAN_ORDER


def test_air_outside_the_box_is_taken_with_a_warning_that_names_each_key():
    """Every value outside the box is named by its key; the box's own corners are silent."""
    inside = model('default', FASTEST[0])
    with warnings.catch_warnings():
        warnings.simplefilter('error', OutsideModelWarning)
        GloveSimulation(inside, actuation='valves')
    air = pneumatics(FASTEST[0])
    air['supply_pressure'] = 300e3
    air['chambers'][1]['dead_volume'] = 1e-8
    air['chambers'][2]['outlet_conductance'] = 5e-9
    data = load_params().to_dict()
    data['pneumatics'] = air
    with pytest.warns(OutsideModelWarning) as caught:
        GloveSimulation(GloveModel(params_from_dict(data)), actuation='valves')
    messages = [str(w.message) for w in caught]
    assert len(messages) == 3
    assert 'pneumatics.supply_pressure = 300000 Pa' in messages[0]
    assert 'pneumatics.chambers[1].dead_volume (pip) = 1e-08 m^3' in messages[1]
    assert 'pneumatics.chambers[2].outlet_conductance (dip) = 5e-09' in messages[2]
    assert all('validated range' in m and 'docs/valves.md' in m for m in messages)
    # a supply left null is the simulation's: its setting is named
    air['supply_pressure'] = None
    air['chambers'] = pneumatics(FASTEST[0])['chambers']
    data['pneumatics'] = air
    with pytest.warns(OutsideModelWarning, match=r'max_supply_pressure \(pneumatics'):
        GloveSimulation(
            GloveModel(params_from_dict(data)),
            SimulationSettings(max_supply_pressure=250e3),
            actuation='valves',
        )
