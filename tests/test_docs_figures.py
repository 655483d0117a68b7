"""Regression pins: the figures of this model that the docs print, read from the docs.

These numbers were computed with this model and typed into the docs; they are not measurements
or the paper's, so they check nothing about the physics (tests/test_model_*.py do that against
independent answers). What they check is that the docs still print what the model computes: a
change of the defaults or the solver that moves one fails here, naming the doc to update. The
figures are read from the docs' own text, to the digits printed (± half the last digit).
"""

import re
from pathlib import Path

import numpy as np
import pytest
from exodigit_model.gym.env import GloveEnv

from exodigit_model import GloveModel, params_from_dict

DOCS = Path(__file__).resolve().parents[1] / 'docs'
NUMBER = r'(-?\d+\.\d+)'
DEFAULT = GloveModel()


def printed(path, pattern):
    """The numbers ``pattern`` captures in ``path`` (under docs/), and their tolerance.

    The tolerance is half a unit of the last digit printed (the same number of decimals each).
    """
    text = ' '.join((DOCS / path).read_text(encoding='utf-8').split())
    match = re.search(pattern, text)
    assert match, f'docs/{path} no longer says {pattern!r}: update this pin with the doc'
    numbers = match.groups()
    decimals = {len(number.split('.')[1]) for number in numbers}
    assert len(decimals) == 1, numbers
    return np.array([float(number) for number in numbers]), 0.5 * 10.0 ** -decimals.pop()


def three(separator, unit=''):
    return separator.join([NUMBER + unit] * 3)


def test_the_spec_prints_the_default_bending_at_50_kpa():
    # docs/spec/model.md §10: free and coupled bending of the defaults at 50 kPa.
    pattern = (
        rf'free bending at 50 kPa is {three("/", "°")} and coupled bending on the finger '
        rf'{three("/", "°")}'
    )
    numbers, tolerance = printed('spec/model.md', pattern)
    p = np.full(3, 50e3)
    computed = np.degrees(np.concatenate([DEFAULT.solve_free(p), DEFAULT.solve(p).q]))
    np.testing.assert_allclose(computed, numbers, rtol=0, atol=tolerance)


@pytest.mark.parametrize(('layer', 'words'), [(0.0, r'E_L = 0'), (100.0, r'E_L = 100 N')])
def test_the_spec_prints_the_mcp_modules_length_at_50_kpa(layer, words):
    # docs/spec/model.md §12: the MCP segment's length on the finger and free at 50 kPa.
    pattern = rf'{NUMBER} vs {NUMBER} mm at {words}'
    (on_finger, free), tolerance = printed('spec/model.md', pattern)
    segments = [{'layer_axial_stiffness': layer}, {}, {}]
    model = GloveModel(params_from_dict({'exo_digit': {'segments': segments}}))
    p = [50e3, 0.0, 0.0]
    assert 1e3 * model.solve(p).lengths[0] == pytest.approx(on_finger, abs=tolerance)
    assert 1e3 * model.solve(p, free=True).lengths[0] == pytest.approx(free, abs=tolerance)


def test_the_gym_guide_prints_the_default_targets_peak():
    # docs/gym.md: the default target peaks at the model's angles at half the supply.
    numbers, tolerance = printed('gym.md', rf'≈ {three(", ")}')
    peak = np.degrees(GloveEnv().target(2.0))
    np.testing.assert_allclose(peak, numbers, rtol=0, atol=tolerance)
