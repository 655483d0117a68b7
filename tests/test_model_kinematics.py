"""Exo-digit and finger kinematics (eqs 1-4, 32-33), Jacobians (docs/spec/model.md §2-3)."""

import math

import numpy as np
import pytest
from model_reference import (
    exo_digit_points,
    finger_points,
    jacobian_by_differences,
    printed_finger_jacobian_transposed,
)

from exodigit_model import GloveModel, load_params, params_from_dict

POSITION_ATOL = 1e-13
"""Positions against eq 4 written with sin/cos, m."""
FD_STEP = 1e-6
"""Central-difference step in q, rad."""
JACOBIAN_ATOL = 1e-9
"""Jacobian entries against central differences of the positions, m."""
RESIDUAL_JACOBIAN_RTOL = 1e-7
"""∂F/∂q against central differences of F, relative to the largest entry."""
EXACT_ATOL = 1e-15
"""Closed forms evaluated two ways (round-off only), m."""
NEAR_ZERO = 1e-12
"""The smallest bending angle checked for smoothness, rad."""

PARAMS = load_params()
LONG_BLOCKS = params_from_dict(
    {
        'exo_digit': {
            'base_block_half_length': 0.017,
            'segments': [
                {'arc_length': 0.05, 'block_half_length': 0.008},
                {'arc_length': 0.02, 'block_half_length': 0.003},
                {'arc_length': 0.03, 'block_half_length': 0.011},
            ],
        },
        'finger': {
            'joints': [{'link_half_length': 0.03}, {'link_half_length': 0.01}, {}],
        },
    }
)
ANGLES = [
    np.array([0.3, 0.2, 0.1]),
    np.array([1.4, 0.9, 0.6]),
    np.array([-0.2, 0.5, -0.35]),
    np.array([2.8, -1.1, 3.0]),
    np.array([0.0, 0.4, 0.0]),
    np.array([1e-3, 1e-4, 0.7]),
]


@pytest.fixture(scope='module', params=['defaults', 'long_blocks'])
def case(request):
    params = PARAMS if request.param == 'defaults' else LONG_BLOCKS
    return params, GloveModel(params)


def _nonzero(q):
    return all(abs(a) > 1e-2 for a in q)


@pytest.mark.parametrize('q', [a for a in ANGLES if _nonzero(a)], ids=str)
def test_pose_matches_eq_4(case, q):
    params, model = case
    origins, ends, centres, normals = exo_digit_points(params, q)
    pose = model.pose(q)
    np.testing.assert_allclose(pose.block_origins, origins, rtol=0, atol=POSITION_ATOL)
    np.testing.assert_allclose(pose.block_ends, ends, rtol=0, atol=POSITION_ATOL)
    np.testing.assert_allclose(pose.contact_points, centres, rtol=0, atol=POSITION_ATOL)
    np.testing.assert_allclose(pose.contact_normals, normals, rtol=0, atol=POSITION_ATOL)


@pytest.mark.parametrize('q', ANGLES, ids=str)
def test_finger_pose_matches_the_hinge_chain(case, q):
    params, model = case
    joints, centres, _ = finger_points(params, q)
    pose = model.pose(q)
    np.testing.assert_allclose(pose.finger_joints, joints, rtol=0, atol=POSITION_ATOL)
    np.testing.assert_allclose(pose.finger_contacts, centres, rtol=0, atol=POSITION_ATOL)


def test_positive_angles_bend_towards_plus_y():
    pose = GloveModel(PARAMS).pose([0.4, 0.4, 0.4])
    assert np.all(pose.block_origins[1:, 1] > 0.0)
    assert np.all(pose.finger_joints[1:, 1] > 0.0)


@pytest.mark.parametrize('q', [a for a in ANGLES if _nonzero(a)], ids=str)
def test_arcs_are_circular_arcs_joining_the_blocks(case, q):
    params, model = case
    samples = 9
    pose = model.pose(q, arc_samples=samples)
    assert pose.arcs.shape == (3, samples, 2)
    phi = np.concatenate([[0.0], np.cumsum(q)])
    for k, segment in enumerate(params.exo_digit.segments):
        arc = pose.arcs[k]
        np.testing.assert_allclose(arc[0], pose.block_ends[k], rtol=0, atol=POSITION_ATOL)
        np.testing.assert_allclose(arc[-1], pose.block_origins[k + 1], rtol=0, atol=POSITION_ATOL)
        # Constant curvature q/ℓ̂: every point lies at ρ = ℓ̂/q from the centre of curvature,
        # which sits on the normal of the proximal block, and the samples are evenly spaced.
        radius = segment.arc_length / q[k]
        centre = arc[0] + radius * np.array([-math.sin(phi[k]), math.cos(phi[k])])
        distance = np.hypot(*(arc - centre).T)
        np.testing.assert_allclose(distance, abs(radius), rtol=1e-12)
        chords = np.hypot(*np.diff(arc, axis=0).T)
        np.testing.assert_allclose(chords, chords[0], rtol=1e-12)


def test_straight_glove_at_zero():
    params = LONG_BLOCKS
    pose = GloveModel(params).pose(np.zeros(3))
    exo = params.exo_digit
    half = [exo.base_block_half_length] + [s.block_half_length for s in exo.segments]
    steps = [2 * half[i] + exo.segments[i].arc_length for i in range(3)]
    origins_x = np.concatenate([[0.0], np.cumsum(steps)])
    np.testing.assert_allclose(pose.block_origins[:, 0], origins_x, rtol=0, atol=EXACT_ATOL)
    assert np.all(pose.block_origins[:, 1] == 0.0)
    assert np.all(pose.finger_joints[:, 1] == 0.0)
    np.testing.assert_array_equal(pose.contact_normals, np.tile([0.0, 1.0], (3, 1)))


@pytest.mark.parametrize('sign', [1.0, -1.0])
def test_pose_is_continuous_through_zero(case, sign):
    # Every point moves by at most (distance from the base) · |Δq| when the angles change.
    _, model = case
    at_zero = model.pose(np.zeros(3))
    near = model.pose(np.full(3, sign * NEAR_ZERO))
    for name in ('block_origins', 'block_ends', 'contact_points', 'arcs', 'finger_joints'):
        a, b = getattr(near, name), getattr(at_zero, name)
        assert np.all(np.isfinite(a))
        assert np.max(np.abs(a - b)) <= 3 * 0.3 * NEAR_ZERO, name


@pytest.mark.parametrize('q', [*ANGLES, np.zeros(3), np.full(3, NEAR_ZERO)], ids=str)
@pytest.mark.parametrize('side', ['robot', 'finger'])
def test_contact_jacobian_is_n_dot_d_centre(case, q, side):
    params, model = case
    robot, finger = model.contact_jacobians(q)
    if side == 'robot':
        jacobian, normals, points = robot, model.pose(q).contact_normals, 'contact_points'
    else:
        jacobian, normals, points = finger, finger_points(params, q)[2], 'finger_contacts'
    expected = jacobian_by_differences(
        lambda a: getattr(model.pose(a), points), normals, q, FD_STEP
    )
    np.testing.assert_allclose(jacobian, expected, rtol=0, atol=JACOBIAN_ATOL)


@pytest.mark.parametrize('q', [*ANGLES, np.zeros(3)], ids=str)
def test_finger_jacobian_is_the_papers_printed_transpose(case, q):
    params, model = case
    _, j_finger = model.contact_jacobians(q)
    np.testing.assert_allclose(
        j_finger.T, printed_finger_jacobian_transposed(params, q), rtol=0, atol=EXACT_ATOL
    )


@pytest.mark.parametrize('q', [*ANGLES, np.zeros(3), np.full(3, -NEAR_ZERO)], ids=str)
def test_jacobians_are_lower_triangular(case, q):
    _, model = case
    for jacobian in model.contact_jacobians(q):
        assert np.all(np.isfinite(jacobian))
        assert np.all(jacobian[np.triu_indices(3, 1)] == 0.0)


@pytest.mark.parametrize('q', [*ANGLES, np.zeros(3), np.full(3, NEAR_ZERO)], ids=str)
def test_robot_diagonal_is_d_plus_arc_term(case, q):
    # docs/spec/model.md §3: d_i + ℓ̂_i (1 - cos q_i)/q_i², written as 2 sin²(q/2)/q² (→ 1/2 at 0).
    params, model = case
    j_robot, _ = model.contact_jacobians(q)
    for i, segment in enumerate(params.exo_digit.segments):
        half = 0.5 * q[i]
        arc_term = 0.5 if half == 0.0 else 0.5 * (math.sin(half) / half) ** 2
        expected = segment.block_half_length + segment.arc_length * arc_term
        assert j_robot[i, i] == pytest.approx(expected, rel=1e-13)
        if abs(q[i]) > 1e-2:
            closed = (
                segment.block_half_length + segment.arc_length * (1 - math.cos(q[i])) / q[i] ** 2
            )
            assert j_robot[i, i] == pytest.approx(closed, rel=1e-12)


@pytest.mark.parametrize('q', [ANGLES[0], ANGLES[2], ANGLES[5], np.zeros(3)], ids=str)
@pytest.mark.parametrize('free', [False, True])
def test_residual_jacobian_equals_finite_differences(case, q, free):
    _, model = case
    p = np.array([35e3, 20e3, 50e3])
    jacobian = model.residual_jacobian(q, p, free=free)
    expected = np.zeros((3, 3))
    for k in range(3):
        step = np.zeros(3)
        step[k] = FD_STEP
        expected[:, k] = (
            model.residual(q + step, p, free=free) - model.residual(q - step, p, free=free)
        ) / (2 * FD_STEP)
    scale = np.max(np.abs(expected))
    np.testing.assert_allclose(jacobian, expected, rtol=0, atol=RESIDUAL_JACOBIAN_RTOL * scale)
