"""Extensible segments (docs/spec/model.md §12): resultants, J_ℓ*, 6×6 solve, inverse, estimator.

Independent references: the resultants by adaptive quad/dblquad over the section
(tests/model_reference.py), J_ℓ* by central differences of eq 4 in the arc lengths (the
reference kinematics of a glove whose arc_length is changed), the 6×6 Jacobian by differences
of the residual, round trips, the inextensible limit, and the figures docs/spec/model.md §12
states.
"""

import math

import numpy as np
import pytest
from exodigit_model.kernels.section import resultants
from model_reference import exo_digit_points, section_integral, yeoh_stress

from exodigit_model import GloveModel, GloveSimulation, SimulationSettings, params_from_dict

NOMINAL = GloveModel()
#: Resultants against adaptive quadrature (relative; docs/spec/model.md §5, §12).
RESULTANT_RTOL = 1e-10
#: Central-difference step (rad, m) and the agreement expected from it.
STEP = 1e-7
DIFFERENCE_RTOL, DIFFERENCE_ATOL = 1e-6, 1e-9
#: Agreement of two converged solves of the same problem: angle (rad), length (m).
ANGLE_TOLERANCE, LENGTH_TOLERANCE = 1e-10, 1e-12


def extensible(*stiffness, material=None):
    """The default glove with ``layer_axial_stiffness`` per segment (None: inextensible)."""
    segments = [{} if e is None else {'layer_axial_stiffness': e} for e in stiffness]
    data = {'exo_digit': {'segments': segments}}
    if material is not None:
        data['material'] = material
    return GloveModel(params_from_dict(data))


def resultants_at(model, q, strain):
    """(M, N, ∂M/∂q, ∂M/∂ε, ∂N/∂q, ∂N/∂ε) per segment from the kernel, arrays (3,)."""
    rows = [resultants(model.constants, k, float(q[k]), float(strain[k])) for k in range(3)]
    m, n, mq, me, ne = np.array(rows).T
    return m, n, mq, me, me / model.constants.arc_lengths, ne


ALL = extensible(0.0, 50.0, 20.0)
MIXED = extensible(0.0, None, 80.0)


# -- resultants (12.2) -----------------------------------------------------------------------


@pytest.mark.parametrize(('q', 'strain'), [(0.3, 0.05), (0.8, 0.2), (-0.1, -0.02), (0.0, 0.1)])
def test_resultants_equal_adaptive_quadrature(q, strain):
    params = ALL.params
    m, n, *_ = resultants_at(ALL, np.full(3, q), np.full(3, strain))
    for k, segment in enumerate(params.exo_digit.segments):

        def stress(y, segment=segment):
            return float(yeoh_stress(params.material, 1.0 + strain + y * q / segment.arc_length))

        moment = section_integral(segment, lambda y, f=stress: f(y) * y)
        force = section_integral(segment, stress)
        assert m[k] == pytest.approx(moment, rel=RESULTANT_RTOL, abs=1e-16)
        assert n[k] == pytest.approx(force, rel=RESULTANT_RTOL, abs=1e-14)


def test_resultant_slopes_equal_differences_and_derive_from_one_potential():
    q, strain = np.array([0.4, 0.5, 0.3]), np.array([0.05, 0.1, 0.02])
    _, _, mq, me, nq, ne = resultants_at(ALL, q, strain)
    up_q, down_q = resultants_at(ALL, q + STEP, strain), resultants_at(ALL, q - STEP, strain)
    up_e, down_e = resultants_at(ALL, q, strain + STEP), resultants_at(ALL, q, strain - STEP)
    for analytic, numeric in (
        (mq, (up_q[0] - down_q[0]) / (2 * STEP)),
        (me, (up_e[0] - down_e[0]) / (2 * STEP)),
        (nq, (up_q[1] - down_q[1]) / (2 * STEP)),
        (ne, (up_e[1] - down_e[1]) / (2 * STEP)),
    ):
        np.testing.assert_allclose(analytic, numeric, rtol=DIFFERENCE_RTOL)
    rest = np.array([s.arc_length for s in ALL.params.exo_digit.segments])
    np.testing.assert_allclose(me, rest * nq, rtol=1e-12)  # ∂M/∂λ_b = ℓ̂ ∂N/∂q


# -- kinematics: J_ℓ* -----------------------------------------------------------------------------


def glove_with_lengths(lengths):
    segments = [{'arc_length': float(length)} for length in lengths]
    return params_from_dict({'exo_digit': {'segments': segments}})


@pytest.mark.parametrize('q', [[0.3, 0.5, 0.2], [1.1, -0.2, 0.7]])
def test_length_jacobian_equals_differences_of_eq_4(q):
    q = np.array(q)
    lengths = np.array([0.05, 0.033, 0.016])
    normals = exo_digit_points(glove_with_lengths(lengths), q)[3]
    numeric = np.zeros((3, 3))
    for k in range(3):
        offset = np.zeros(3)
        offset[k] = 1e-6
        up = exo_digit_points(glove_with_lengths(lengths + offset), q)[2]
        down = exo_digit_points(glove_with_lengths(lengths - offset), q)[2]
        numeric[:, k] = np.sum(normals * (up - down) / 2e-6, axis=1)
    np.testing.assert_allclose(NOMINAL.length_jacobian(q, lengths), numeric, atol=1e-8)
    assert np.allclose(np.triu(NOMINAL.length_jacobian(q, lengths), 1), 0.0)


# -- the coupled system -----------------------------------------------------------------------


@pytest.mark.parametrize('model', [ALL, MIXED], ids=['all', 'mixed'])
def test_the_6x6_jacobian_equals_differences_of_the_residual(model):
    q = np.array([0.35, 0.4, 0.25])
    lengths = np.array([0.049, 0.031, 0.0157])
    if model is MIXED:
        lengths[1] = 0.031  # the inextensible PIP keeps its rest length
    p = np.array([40e3, 30e3, 20e3])
    kwargs = {'effort': [0.002, 0.0, 0.001], 'q_previous': q - 0.01, 'dt': 0.01}
    analytic = model.residual_jacobian(q, p, lengths=lengths, **kwargs)
    assert analytic.shape == (6, 6)
    numeric = np.zeros((6, 6))
    rest = np.asarray(model.constants.arc_lengths)
    for m in range(6):
        dq, dl = np.zeros(3), np.zeros(3)
        if m < 3:
            dq[m] = STEP
        else:
            dl[m - 3] = STEP * rest[m - 3]  # a step of STEP in the strain
        up = model.residual(q + dq, p, lengths=lengths + dl, **kwargs)
        down = model.residual(q - dq, p, lengths=lengths - dl, **kwargs)
        numeric[:, m] = (up - down) / (2 * STEP)
    np.testing.assert_allclose(analytic, numeric, rtol=DIFFERENCE_RTOL, atol=DIFFERENCE_ATOL)


def test_an_inextensible_layer_is_todays_model_exactly():
    explicit = extensible(math.inf, math.inf, math.inf)
    assert not explicit.extensible
    for p in ([50e3, 50e3, 50e3], [40e3, 10e3, 0.0]):
        today, same = NOMINAL.solve(p), explicit.solve(p)
        np.testing.assert_array_equal(same.q, today.q)
        np.testing.assert_array_equal(same.forces, today.forces)
        np.testing.assert_array_equal(same.lengths, [0.046, 0.031, 0.015])


def test_a_stiffening_layer_converges_to_the_constant_length_model():
    p = np.array([50e3, 40e3, 30e3])
    reference = NOMINAL.solve(p)
    errors = []
    for stiffness in (1e3, 1e5, 1e7):
        solution = extensible(stiffness, stiffness, stiffness).solve(p)
        assert solution.converged, solution.message
        errors.append(np.abs(solution.q - reference.q).max())
        assert np.all(solution.lengths > reference.lengths)  # pressure stretches the layer
    assert errors[0] > errors[1] > errors[2] and errors[2] < 1e-5
    assert errors[1] / errors[2] == pytest.approx(100.0, rel=0.1)  # first order in 1/E_L


def test_the_mcp_module_is_longer_on_the_finger_than_free():
    # The paper's observation (docs/spec/model.md §12), at 50 kPa on the MCP segment; the
    # lengths the spec prints are pinned in tests/test_docs_figures.py.
    for stiffness in (0.0, 100.0):
        model = extensible(stiffness, None, None)
        finger = model.solve([50e3, 0.0, 0.0])
        alone = model.solve([50e3, 0.0, 0.0], free=True)
        assert finger.converged and alone.converged
        assert finger.lengths[0] > alone.lengths[0] > model.constants.arc_lengths[0]


@pytest.mark.parametrize('free', [False, True])
def test_length_grows_monotonically_with_pressure(free):
    pressures = np.linspace(0.0, 60e3, 13)
    lengths = np.array([ALL.solve(np.full(3, p), free=free).lengths for p in pressures])
    np.testing.assert_allclose(lengths[0], ALL.constants.arc_lengths, atol=1e-9)
    assert np.all(np.diff(lengths, axis=0) > 0.0)


def test_free_motion_balances_each_segment_alone():
    p = np.array([45e3, 25e3, 10e3])
    solution = ALL.solve(p, free=True)
    residual = ALL.residual(solution.q, p, free=True, lengths=solution.lengths)
    assert np.abs(residual).max() < 1e-14
    np.testing.assert_array_equal(solution.forces, np.zeros(3))
    single = extensible(0.0, None, None).solve([45e3, 0.0, 0.0], free=True)
    assert single.q[0] == pytest.approx(solution.q[0], abs=ANGLE_TOLERANCE)  # decoupled


def test_a_batch_equals_single_solves():
    pressures = np.random.default_rng(3).uniform(0.0, 60e3, (12, 3))
    batch = MIXED.solve_batch(pressures)
    assert batch.converged.all()
    for row, p in enumerate(pressures):
        single = MIXED.solve(p)
        np.testing.assert_allclose(batch.q[row], single.q, atol=ANGLE_TOLERANCE)
        np.testing.assert_allclose(batch.lengths[row], single.lengths, atol=LENGTH_TOLERANCE)
        np.testing.assert_allclose(batch.forces[row], single.forces, atol=1e-9)


# -- inverse and estimator -------------------------------------------------------------------


@pytest.mark.parametrize('model', [ALL, MIXED], ids=['all', 'mixed'])
def test_inverse_and_estimator_round_trip(model):
    p = np.array([40e3, 30e3, 20e3])
    solution = model.solve(p)
    held = model.hold(solution.q)
    np.testing.assert_allclose(held.pressure, p, rtol=1e-9)
    np.testing.assert_allclose(held.lengths, solution.lengths, atol=LENGTH_TOLERANCE)
    estimate = model.estimate(solution.q, p)
    np.testing.assert_allclose(estimate.forces, solution.forces, rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(estimate.lengths, solution.lengths, atol=LENGTH_TOLERANCE)
    batch = model.estimate_forces_batch([solution.q], [p])[0]
    np.testing.assert_allclose(batch, estimate.forces)


def test_the_valid_range_is_judged_over_the_whole_section():
    straight = np.zeros(3)
    model = ALL
    assert model.in_valid_range(straight, [-0.04, 0.0, 0.0])  # 0.96: slightly compressed
    assert not model.in_valid_range(straight, [-0.06, 0.0, 0.0])  # 0.94
    assert not model.in_valid_range(straight, [0.55, 0.0, 0.0])  # the bottom face at 1.55
    # (12.1) at the top fibre y = h: λ = λ_b + h·q/ℓ̂; bend segment 1 to a top of 1.5 - 1e-4.
    first = model.params.exo_digit.segments[0]
    bottom = 1.1
    angle = (1.5 - 1e-4 - bottom) * first.arc_length / first.height
    q = np.array([angle, 0.1, 0.1])
    assert model.in_valid_range(q, [bottom - 1.0, 0.0, 0.0])
    assert not model.in_valid_range(q, [bottom - 1.0 + 2e-4, 0.0, 0.0])


def test_the_stepper_reports_the_solved_lengths():
    simulation = GloveSimulation(ALL, SimulationSettings(pressure_time_constant=0.0))
    for level in (10e3, 30e3, 50e3, 20e3):
        state = simulation.step(np.full(3, level))
        expected = ALL.solve(np.full(3, level))
        np.testing.assert_allclose(state.lengths, expected.lengths, atol=LENGTH_TOLERANCE)
        np.testing.assert_allclose(state.q, expected.q, atol=ANGLE_TOLERANCE)
    batch = GloveSimulation(ALL, SimulationSettings(pressure_time_constant=0.0), count=2)
    state = batch.step(np.array([[10e3] * 3, [50e3] * 3]))
    np.testing.assert_allclose(state.lengths[1], ALL.solve([50e3] * 3).lengths, atol=1e-11)
