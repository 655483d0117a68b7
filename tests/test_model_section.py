"""Pressure moment (eq 12) and structural torque (eq 27) against adaptive scipy quadrature."""

import math

import numpy as np
import pytest
from exodigit_model.physics.section import pressure_moment
from model_reference import (
    region_first_moment,
    resisting_moment,
    section_height,
    section_second_moment,
)

from exodigit_model import GloveModel, Segment, load_params, params_from_dict

QUAD_RTOL = 1e-10
"""τ_s against adaptive quadrature, relative (issue 2's accuracy target)."""
MOMENT_RTOL = 1e-12
"""Eq 12 against the region's first moment by dblquad, relative."""
FD_STEP = 1e-4
"""Central-difference step in q, rad."""
FD_RTOL = 1e-7
"""dτ_s/dq against a central difference of the reference moment, relative."""
SMALL_ANGLE_RTOL = 1e-9
"""Linearisation at q → 0 against the exact small-angle stiffness, relative."""

OTHER = params_from_dict(
    {
        'material': {'c1': 3.5e5, 'c2': -2.0e4, 'c3': 4.0e3},
        'exo_digit': {
            'segments': [
                {'arc_length': 0.052, 'wall_height': 0.0055, 'base_thickness': 0.001},
                {'inner_radius': 0.0045, 'wall_thickness': 0.0016},
                {'arc_length': 0.011, 'wall_height': 0.002, 'base_thickness': 0.0021},
            ]
        },
    }
)
PARAM_SETS = {'defaults': load_params(), 'other': OTHER}


@pytest.fixture(scope='module', params=sorted(PARAM_SETS))
def case(request):
    params = PARAM_SETS[request.param]
    return params, GloveModel(params)


def _joint_angles(joint, angle):
    q = np.zeros(3)
    q[joint] = angle
    return q


def _valid_limit(segment):
    """q at which the top fibre reaches λ = 1.5 (docs/spec/model.md §5: λ(y) = 1 + y q/ℓ̂)."""
    return 0.5 * segment.arc_length / section_height(segment)


SEGMENTS = [
    *load_params().exo_digit.segments,
    *OTHER.exo_digit.segments,
    Segment('flat', 0.02, 0.002, 0.0005, 0.0001, 0.003, 0.004, math.inf),
    Segment('tall', 0.02, 0.01, 0.003, 0.02, 0.0002, 0.004, math.inf),
]


@pytest.mark.parametrize('segment', SEGMENTS, ids=lambda s: s.name)
def test_eq_12_is_the_first_moment_of_the_region_above_the_base(segment):
    assert pressure_moment(segment) == pytest.approx(region_first_moment(segment), rel=MOMENT_RTOL)


def test_pressure_torque_is_b_r_times_p(case):
    params, model = case
    moments = [region_first_moment(s) for s in params.exo_digit.segments]
    np.testing.assert_allclose(model.constants.pressure_moments, moments, rtol=MOMENT_RTOL)
    p = np.array([12e3, 37.5e3, 60e3])
    np.testing.assert_allclose(model.pressure_torque(p), np.array(moments) * p, rtol=MOMENT_RTOL)


@pytest.mark.parametrize('joint', range(3))
def test_structural_torque_equals_quadrature_over_the_valid_range(case, joint):
    params, model = case
    segment = params.exo_digit.segments[joint]
    for angle in np.linspace(0.0, _valid_limit(segment), 13)[1:]:
        expected = -resisting_moment(params.material, segment, angle)
        got = model.structural_torque(_joint_angles(joint, angle))[joint]
        assert got == pytest.approx(expected, rel=QUAD_RTOL), f'q = {angle}'


@pytest.mark.parametrize('joint', range(3))
@pytest.mark.parametrize('multiple', [-0.6, -0.2, 1.3, 2.4, 3.5])
def test_structural_torque_equals_quadrature_outside_the_valid_range(case, joint, multiple):
    # Compression of the top fibre (q < 0) and stretches up to λ = 2.75 (beyond any table).
    params, model = case
    segment = params.exo_digit.segments[joint]
    angle = multiple * _valid_limit(segment)
    expected = -resisting_moment(params.material, segment, angle)
    got = model.structural_torque(_joint_angles(joint, angle))[joint]
    assert got == pytest.approx(expected, rel=QUAD_RTOL)


@pytest.mark.parametrize('joint', range(3))
def test_structural_stiffness_is_the_slope_of_the_quadrature(case, joint):
    params, model = case
    segment = params.exo_digit.segments[joint]
    for angle in np.linspace(-0.3, 1.2, 6) * _valid_limit(segment):
        slope = -(
            resisting_moment(params.material, segment, angle + FD_STEP)
            - resisting_moment(params.material, segment, angle - FD_STEP)
        ) / (2.0 * FD_STEP)
        got = model.structural_stiffness(_joint_angles(joint, angle))[joint]
        assert got == pytest.approx(slope, rel=FD_RTOL), f'q = {angle}'


def test_structural_torque_resists_bending(case):
    _, model = case
    q = np.array([0.3, 0.2, 0.1])
    assert np.all(model.structural_torque(q) < 0.0)
    assert np.all(model.structural_torque(-q) > 0.0)
    assert np.all(model.structural_stiffness(q) < 0.0)


def test_zero_bending_gives_exactly_zero_torque(case):
    _, model = case
    assert np.array_equal(model.structural_torque(np.zeros(3)), np.zeros(3))


@pytest.mark.parametrize('angle', [0.0, 1e-12, -1e-12, 1e-9])
def test_torque_near_zero_is_the_linear_small_angle_law(case, angle):
    # σ ≈ 8 C1 (λ - 1) for λ → 1, so M ≈ 8 C1 q ∫ y² dA / ℓ̂: finite and smooth through 0.
    params, model = case
    segments = params.exo_digit.segments
    stiffness = np.array(
        [8.0 * params.material.c1 * section_second_moment(s) / s.arc_length for s in segments]
    )
    q = np.full(3, angle)
    np.testing.assert_allclose(
        model.structural_torque(q), -stiffness * angle, rtol=SMALL_ANGLE_RTOL, atol=0.0
    )
    np.testing.assert_allclose(
        model.structural_stiffness(q), -stiffness, rtol=SMALL_ANGLE_RTOL, atol=0.0
    )


def test_rows_of_angles_give_the_same_torques_as_single_states(case):
    _, model = case
    rows = np.array([[0.0, 0.1, -0.05], [0.9, 0.6, 0.3], [2.5, 3.0, 1.2], [1e-12, 0.0, -0.4]])
    torque, slope = model.structural_torque(rows), model.structural_stiffness(rows)
    assert torque.shape == slope.shape == rows.shape
    for row, t, s in zip(rows, torque, slope, strict=True):
        np.testing.assert_allclose(t, model.structural_torque(row), rtol=1e-13, atol=0.0)
        np.testing.assert_allclose(s, model.structural_stiffness(row), rtol=1e-13, atol=0.0)
