"""The valve_command check (exodigit_nodes.logic.inputs.valve_openings; no ROS, fast)."""

import math

import numpy as np
import pytest
from exodigit_nodes.logic.inputs import InvalidInputError, joint_vector, valve_openings


@pytest.mark.parametrize('length', [0, 3, 5, 7, 12])
def test_a_valve_command_of_the_wrong_length_is_rejected(length):
    with pytest.raises(InvalidInputError, match=r'needs 6 values \(inlet MCP') as caught:
        valve_openings([0.5] * length, 'valve_command')
    assert caught.value.kind == 'wrong length'


@pytest.mark.parametrize('bad', [math.nan, math.inf, -math.inf])
def test_a_non_finite_valve_command_is_rejected(bad):
    with pytest.raises(InvalidInputError, match='non-finite') as caught:
        valve_openings([0.0, 0.1, bad, 1.0, 0.0, 0.0], 'valve_command')
    assert caught.value.kind == 'non-finite'


@pytest.mark.parametrize('bad', [-1e-9, 1.0 + 1e-9, -1.0, 2.0])
def test_an_opening_outside_0_1_is_refused_not_clipped(bad):
    with pytest.raises(InvalidInputError, match=r'outside \[0, 1\]') as caught:
        valve_openings([0.0, 0.0, 0.0, 1.0, bad, 0.0], 'valve_command')
    assert caught.value.kind == 'out of range'


def test_openings_at_the_ends_and_between_pass_unchanged():
    data = [0.0, 1.0, 0.25, 1.0, 0.0, 3e-310]
    np.testing.assert_array_equal(valve_openings(data, 'valve_command'), data)


def test_the_pressure_command_check_keeps_its_reasons():
    """The length and finiteness checks are shared; a joint vector's reasons are unchanged."""
    with pytest.raises(InvalidInputError, match=r'needs 3 values \(MCP, PIP, DIP\), got 6'):
        joint_vector([0.0] * 6, 'pressure_command')
    with pytest.raises(InvalidInputError, match='non-finite'):
        joint_vector([0.0, math.nan, 0.0], 'pressure_command')
