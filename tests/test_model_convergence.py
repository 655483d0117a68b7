"""Every solve converges where the model holds, or says why (issue 15, item 4).

Property tests (hypothesis) of every API that solves something: the coupled solve, the stepped
solve, the free solve, the batch, the inverse (``hold``/``pressure_for``), the robot-side
estimator (``estimate``/``estimate_forces``), the identification fit and the simulation step,
over

- the layer stiffness E_L of each segment on its own (docs/spec/model.md §12): 0, ``.inf`` or
  log-uniform in [1e-6, 1e9] N. The elastomer's own axial stiffness ∂N/∂ε is about 43 N at rest,
  so 1e-6 N stands for "no layer" and 1e9 N behaves as the inextensible layer;
- the glove scaled by s (lengths) and m (stresses), each log-uniform in [1e-3, 1e3]. Stresses
  scale with m and areas with s², so every moment (τ_s, r_pA_p·p, the finger's torques) scales with
  m·s³, every force (f, N, p·A_p, E_L·ε) with m·s², and angles and strains stay the same: the
  pressures and Yeoh coefficients go × m, the finger's N·m/rad, N·m and N·m·s/rad × m·s³, E_L ×
  m·s². The angles must come out the same to ~1e-9;
- the four patient presets by name, and random patients within the documented ranges
  (:func:`documented_range`: docs/patients.md);
- pressures in the supply range, 0-100 kPa (× m; ``SimulationSettings.max_supply_pressure``).

Every state of these ranges must converge, inside the validated stretch and range of motion or
not: the exploration behind this file (about 10⁵ states of every API) found no forward solve that
fails there. Where a state leaves the validated range or the finger's range of motion,
``in_valid_range`` and ``in_range_of_motion`` must say so: both are checked against an
independent evaluation of (12.1) and of the range of motion from the parameters. A finger pushed
past its range by the patient's own effort may fail to converge, but then the flags must say
why.

Hypothesis runs derandomized here: the same examples every run, so that the shared suite stays
deterministic (the properties also passed with random seeds and eight times the examples). The
failures the exploration found are pinned by the regressions at the end.
"""

import math
import re
import warnings

import numpy as np
import pytest
from exodigit_model.physics.solver import MIN_STRETCH
from exodigit_model.physics.validity import BEYOND_SUPPLY, OUTSIDE_STRETCH
from hypothesis import given, settings
from hypothesis import strategies as st
from model_reference import SEGMENT_LENGTH_KEYS

from exodigit_model import (
    PATIENT_PRESETS,
    GloveModel,
    GloveSimulation,
    OutsideModelWarning,
    SimulationSettings,
    load_params,
    params_from_dict,
    patient_file,
)

SUPPLY = 100e3
"""The supply range of the chambers, Pa (SimulationSettings.max_supply_pressure)."""
VALID_STRETCH = (0.95, 1.5)
"""The validated fibre stretches of docs/spec/model.md §12 (written here, not imported)."""
ANGLE_RTOL = 1e-9
"""Angles of equivalent problems agree to this, relative to the state's largest angle."""
ANGLE_FLOOR = 1e-14
"""... plus this, rad (a state at rest has angles of rounding size)."""
FORCE_RTOL = 1e-7
"""Robot-side and finger-side forces agree to this, relative to the largest force ..."""
FORCE_FLOOR = 1e-10
"""... plus this, N at unit scale (× m·s²)."""
DT = 0.01
"""Time step of the stepped solves, s."""
STEPS = 4
"""Steps of each simulation run."""
EXAMPLES = 12
"""Examples of a property (some take more or fewer): each builds one or two gloves (50-100 ms
each), so that the file runs in about 20 s on the shared 2-core machine."""

FINGER_TORQUES = ('stiffness', 'rom_torque', 'damping', 'spasticity', 'extensor_spasticity')
"""Joint keys in N·m/rad, N·m or N·m·s/rad (× m·s³)."""
JOINT_KEYS = (
    *FINGER_TORQUES,
    'rest_angle',
    'rom_min',
    'rom_max',
    'rom_sharpness',
    'spasticity_threshold',
)
"""The patient's keys (docs/spec/model.md §11)."""
PRESET_JOINTS = {
    name: load_params(patient_file(name)).to_dict()['finger']['joints'] for name in PATIENT_PRESETS
}
PROPERTY = {'derandomize': True, 'deadline': None}
"""Settings of every property (see the module docstring)."""


# -- gloves ----------------------------------------------------------------------------------


def glove_data(layers, joints=None, s=1.0, m=1.0):
    """The default glove with E_L ``layers`` (N) on ``joints`` (None: the paper's finger).

    The glove and finger scaled by s (lengths) and m (stresses) as the module docstring says.
    """
    data = load_params().to_dict()
    if joints is not None:
        for joint, values in zip(data['finger']['joints'], joints, strict=True):
            joint.update({key: values[key] for key in JOINT_KEYS})
    exo = data['exo_digit']
    exo['base_block_half_length'] *= s
    for segment, layer in zip(exo['segments'], layers, strict=True):
        for key in SEGMENT_LENGTH_KEYS:
            segment[key] *= s
        segment['layer_axial_stiffness'] = layer * m * s * s
    data['material'] = {key: value * m for key, value in data['material'].items()}
    for joint in data['finger']['joints']:
        joint['link_half_length'] *= s
        for key in FINGER_TORQUES:
            joint[key] *= m * s**3
    return data


def glove(layers, joints=None, s=1.0, m=1.0):
    return GloveModel(params_from_dict(glove_data(layers, joints, s, m)))


def preset_glove(name, layers):
    return glove(layers, PRESET_JOINTS[name])


def expected_flags(params, q, lengths):
    """(in_valid_range, in_range_of_motion) of angles q and lengths ℓ, from (12.1) and the ROM.

    The extreme fibres are the bottom face, λ_b = ℓ/ℓ̂, and the top, λ_b + q (b + h + r0 + t)/ℓ̂.
    """
    low, high = VALID_STRETCH
    valid = moving = True
    for k, (segment, joint) in enumerate(
        zip(params.exo_digit.segments, params.finger.joints, strict=True)
    ):
        rest = segment.arc_length
        height = (
            segment.base_thickness
            + segment.wall_height
            + segment.inner_radius
            + segment.wall_thickness
        )
        bottom = lengths[k] / rest
        top = bottom + q[k] * height / rest
        valid = valid and low <= bottom <= high and low <= top <= high
        moving = moving and joint.rom_min <= q[k] <= joint.rom_max
    return valid, moving


def assert_flags(model, q, lengths, in_valid_range, in_range_of_motion):
    """The result's flags say what an independent evaluation of the state says."""
    valid, moving = expected_flags(model.params, q, lengths)
    assert bool(in_valid_range) == valid, (q, lengths)
    assert bool(in_range_of_motion) == moving, q


def assert_converged(model, solution):
    assert solution.converged, (solution.message, solution.q, solution.lengths)
    assert np.all(np.isfinite(solution.q)) and np.all(np.isfinite(solution.forces))
    assert_flags(
        model, solution.q, solution.lengths, solution.in_valid_range, solution.in_range_of_motion
    )


def assert_same_angles(q, reference):
    size = float(np.max(np.abs(reference)))
    np.testing.assert_allclose(q, reference, rtol=0, atol=ANGLE_RTOL * size + ANGLE_FLOOR)


def assert_holds(model, q, pressure, lengths, **finger):
    """Forward of the inverse: the solve started at the inverse's state stays at angles ``q``."""
    start = model.solve_batch(
        pressure[None], np.asarray(q)[None], lengths0=lengths[None], **finger
    )
    assert start.converged[0], (start.message[0], pressure, lengths)
    assert_same_angles(start.q[0], q)


def assert_same_forces(forces, reference, force_scale):
    size = float(np.max(np.abs(reference)))
    np.testing.assert_allclose(
        forces, reference, rtol=0, atol=FORCE_RTOL * size + FORCE_FLOOR * force_scale
    )


# -- strategies ------------------------------------------------------------------------------

layer_stiffness = st.one_of(
    st.just(0.0),
    st.just(math.inf),
    st.just(1e9),
    st.floats(-6.0, 9.0).map(lambda exponent: 10.0**exponent),
)
"""E_L of one segment, N: 0, .inf, 1e9 or log-uniform in [1e-6, 1e9]."""
layers = st.tuples(layer_stiffness, layer_stiffness, layer_stiffness)
scale = st.floats(-3.0, 3.0).map(lambda exponent: 10.0**exponent)
"""s or m, log-uniform in [1e-3, 1e3]."""
chamber = st.one_of(st.just(0.0), st.just(SUPPLY), st.floats(0.0, SUPPLY, allow_subnormal=False))
pressures = st.tuples(chamber, chamber, chamber).map(np.array)
"""Three chamber pressures in the supply range, Pa."""


def documented_range(joint, key):
    """The documented range of a patient parameter of joint 0-2 (MCP, PIP, DIP).

    docs/patients.md, "The values": from the lowest to the highest value of the four presets
    (read from the preset files the table describes). The stiffness goes wider, over the measured
    index-MCP span of "How the values were chosen" (healthy 0.033 to MAS 3 0.64 N·m/rad [1]),
    with PIP and DIP scaled by the paper's ratios 0.75 and 0.375 as the presets are.
    """
    if key == 'stiffness':
        ratio = (1.0, 0.75, 0.375)[joint]
        return 0.033 * ratio, 0.64 * ratio
    values = [PRESET_JOINTS[name][joint][key] for name in PATIENT_PRESETS]
    return min(values), max(values)


@st.composite
def random_patient(draw):
    """Three joints, every value drawn within its documented range (rest within the ROM)."""
    joints = []
    for joint in range(3):
        values = {key: draw(st.floats(*documented_range(joint, key))) for key in JOINT_KEYS}
        low, high = documented_range(joint, 'rest_angle')
        low, high = max(low, values['rom_min']), min(high, values['rom_max'])
        values['rest_angle'] = draw(st.floats(low, high))
        joints.append(values)
    return joints


patients = st.one_of(
    st.none(), st.sampled_from(PATIENT_PRESETS).map(PRESET_JOINTS.get), random_patient()
)
"""The paper's linear finger, a preset or a random patient."""


# -- every API at every layer stiffness -------------------------------------------------------


def check_every_api(model, p, p_before, force_scale=1.0):
    """Each API at pressures ``p`` (the finger coming from its state at ``p_before``).

    ``force_scale``: m·s² of a scaled glove. Returns the static solution at ``p``.
    """
    solution = model.solve(p)
    assert_converged(model, solution)
    before = model.solve(p_before)
    assert_converged(model, before)

    free = model.solve(p, free=True)
    assert_converged(model, free)
    np.testing.assert_array_equal(free.forces, np.zeros(3))
    assert_same_angles(model.solve_free(p), free.q)  # a non-converged free solve warns: error

    stepped = model.solve(p, q0=before, q_previous=before.q, dt=DT)
    assert_converged(model, stepped)

    batch = model.solve_batch(np.stack([p, p_before]))
    assert batch.converged.all(), batch.message
    for row, single in enumerate((solution, before)):
        assert_same_angles(batch.q[row], single.q)
        flags = batch.in_valid_range[row], batch.in_range_of_motion[row]
        assert_flags(model, batch.q[row], batch.lengths[row], *flags)

    held = model.hold(solution.q)  # raises where no strain balances
    assert_holds(model, solution.q, held.pressure, held.lengths)
    assert_flags(model, held.q, held.lengths, held.in_valid_range, held.in_range_of_motion)
    with warnings.catch_warnings():  # the state may lie outside: the shortcut warns then
        warnings.simplefilter('ignore', OutsideModelWarning)
        np.testing.assert_array_equal(model.pressure_for(solution.q), held.pressure)
    if not model.extensible:  # the inverse is unique at constant length (eq 36 for p)
        np.testing.assert_allclose(held.pressure, p, rtol=0, atol=1e-9 * SUPPLY)

    estimate = model.estimate(solution.q, p)  # raises where no strain balances
    assert_same_forces(estimate.forces, solution.forces, force_scale)
    np.testing.assert_allclose(estimate.lengths, solution.lengths, rtol=1e-9)
    flags = estimate.in_valid_range, estimate.in_range_of_motion
    assert_flags(model, solution.q, estimate.lengths, *flags)
    with warnings.catch_warnings():
        warnings.simplefilter('ignore', OutsideModelWarning)
        np.testing.assert_array_equal(model.estimate_forces(solution.q, p), estimate.forces)

    settings_ = SimulationSettings(pressure_time_constant=0.0, max_supply_pressure=SUPPLY)
    simulation = GloveSimulation(model, settings_)
    run = simulation.run(np.stack([p_before] * (STEPS // 2) + [p] * (STEPS - STEPS // 2)))
    assert run.converged.all(), run.residual
    for t in range(STEPS):
        flags = run.in_valid_range[t], run.in_range_of_motion[t]
        assert_flags(model, run.q[t], run.lengths[t], *flags)
    return solution


@settings(max_examples=3 * EXAMPLES, **PROPERTY)
@given(layers=layers, joints=patients, p=pressures, p_before=pressures)
def test_every_api_converges_at_every_layer_stiffness(layers, joints, p, p_before):
    check_every_api(glove(layers, joints), p, p_before)


@pytest.mark.parametrize('name', PATIENT_PRESETS)
@settings(max_examples=EXAMPLES // 2, **PROPERTY)
@given(layers=layers, p=pressures, p_before=pressures)
def test_every_api_converges_for_each_preset(name, layers, p, p_before):
    check_every_api(preset_glove(name, layers), p, p_before)


@settings(max_examples=EXAMPLES // 2, **PROPERTY)
@given(joints=patients, p=pressures, segment=st.integers(0, 2))
def test_a_stiff_layer_is_the_inextensible_model(joints, p, segment):
    # docs/spec/model.md §12: E_L -> inf is the constant-length model; at 1e9 N (7 orders above the
    # elastomer's own axial stiffness) the angles differ by O(1/E_L).
    stiff = [math.inf] * 3
    stiff[segment] = 1e9
    constant = glove([math.inf] * 3, joints).solve(p)
    stretching = glove(stiff, joints).solve(p)
    assert constant.converged and stretching.converged
    np.testing.assert_allclose(stretching.q, constant.q, rtol=0, atol=1e-6)


FIT_DESIGN = np.array(
    [
        [0.0, 0.0, 0.0],
        [1.0, 0.0, 0.0],
        [0.0, 1.0, 0.0],
        [0.0, 0.0, 1.0],
        [1.0, 1.0, 1.0],
        [0.5, 0.5, 0.5],
        [1.0, 0.3, 0.6],
    ]
)
"""Pressures of the identification, as fractions of the highest: every joint moves."""


# -- the same problem at any scale -------------------------------------------------------------


# Drawn gloves and pressures may leave the validated range: scaling holds there too.
@pytest.mark.filterwarnings('ignore::exodigit_model.physics.validity.OutsideModelWarning')
@settings(max_examples=2 * EXAMPLES, **PROPERTY)
@given(
    layers=layers,
    joints=patients,
    s=scale,
    m=scale,
    p=pressures,
    p_before=pressures,
    effort=st.tuples(*[st.floats(-0.01, 0.01)] * 3).map(np.array),
    highest=st.floats(0.3 * SUPPLY, SUPPLY),
)
def test_a_scaled_glove_gives_the_same_angles(layers, joints, s, m, p, p_before, effort, highest):
    reference, scaled = glove(layers, joints), glove(layers, joints, s, m)
    force_scale = m * s * s
    solution = check_every_api(scaled, m * p, m * p_before, force_scale)
    expected = reference.solve(p)
    assert_same_angles(solution.q, expected.q)
    np.testing.assert_allclose(solution.lengths, s * expected.lengths, rtol=1e-12)
    assert_same_forces(solution.forces, force_scale * expected.forces, force_scale)
    free, expected_free = scaled.solve(m * p, free=True), reference.solve(p, free=True)
    assert_same_angles(free.q, expected_free.q)
    np.testing.assert_allclose(free.lengths, s * expected_free.lengths, rtol=1e-12)

    torque = m * s**3 * effort  # the patient's effort, N·m, scales as a moment
    before, expected_before = scaled.solve(m * p_before), reference.solve(p_before)
    stepped = scaled.solve(m * p, q0=before, effort=torque, q_previous=before.q, dt=DT)
    expected_stepped = reference.solve(
        p, q0=expected_before, effort=effort, q_previous=expected_before.q, dt=DT
    )
    assert stepped.converged and expected_stepped.converged
    assert_same_angles(stepped.q, expected_stepped.q)

    held, expected_held = scaled.hold(solution.q, supply=m * SUPPLY), reference.hold(expected.q)
    np.testing.assert_allclose(
        held.pressure, m * expected_held.pressure, rtol=0, atol=1e-9 * m * SUPPLY
    )
    np.testing.assert_allclose(held.lengths, s * expected_held.lengths, rtol=1e-9)

    estimate = scaled.estimate(solution.q, m * p)
    expected_estimate = reference.estimate(expected.q, p)
    assert_same_forces(estimate.forces, force_scale * expected_estimate.forces, force_scale)

    commands = np.array([p_before, p, p, p])
    run = GloveSimulation(scaled, SimulationSettings(max_supply_pressure=m * SUPPLY)).run(
        m * commands
    )
    expected_run = GloveSimulation(reference, SimulationSettings()).run(commands)
    assert run.converged.all() and expected_run.converged.all()
    for t in range(len(commands)):
        assert_same_angles(run.q[t], expected_run.q[t])

    fits = []  # the identification of any patient, from static states
    for model, stress in ((reference, 1.0), (scaled, m)):
        batch = model.solve_batch(stress * highest * FIT_DESIGN)
        assert batch.converged.all(), batch.message
        fits.append(model.fit_stiffness(batch.q, stress * highest * FIT_DESIGN))
    expected_fit, fit = fits
    assert np.all(np.isfinite(fit.stiffness)) and np.all(np.isfinite(fit.rmse))
    np.testing.assert_allclose(fit.stiffness, m * s**3 * expected_fit.stiffness, rtol=1e-6)
    np.testing.assert_allclose(fit.rest_angle, expected_fit.rest_angle, rtol=0, atol=1e-7)


@settings(max_examples=EXAMPLES // 2, **PROPERTY)
@given(layers=layers, s=scale, m=scale, highest=st.floats(0.3 * SUPPLY, SUPPLY))
def test_the_fit_recovers_a_linear_finger_at_any_scale(layers, s, m, highest):
    # The paper's linear finger: the robot-side estimate is exact, so the fit is k and q_r = 0
    # at any E_L, and its stiffness scales with m s^3.
    model = glove(layers, None, s, m)
    batch = model.solve_batch(m * highest * FIT_DESIGN)
    assert batch.converged.all(), batch.message
    fit = model.fit_stiffness(batch.q, m * highest * FIT_DESIGN)
    stiffness = np.array([joint.stiffness for joint in model.params.finger.joints])
    np.testing.assert_allclose(fit.stiffness, stiffness, rtol=1e-7)
    np.testing.assert_allclose(fit.rest_angle, 0.0, rtol=0, atol=1e-7)


# -- beyond the model: the results say so ------------------------------------------------------


@settings(max_examples=EXAMPLES, **PROPERTY)
@given(
    layers=layers,
    joints=patients,
    p=pressures,
    effort=st.tuples(*[st.floats(-0.1, 0.1)] * 3).map(np.array),
)
def test_an_effort_past_the_range_is_converged_or_flagged(layers, joints, p, effort):
    # The patient's own effort (up to 0.1 N·m, the size of the severe MCP's spastic torque in
    # docs/patients.md) can push a joint past its range or a fibre past its validated stretch.
    # There a solve may stop, but only with its flags saying which condition failed; the flags
    # always describe the returned state.
    model = glove(layers, joints)
    start = model.solve(p)
    assert_converged(model, start)
    for solution in (
        model.solve(p, q0=start, effort=effort),
        model.solve(p, q0=start, effort=effort, q_previous=start.q, dt=DT),
    ):
        assert np.all(np.isfinite(solution.q))
        assert_flags(
            model,
            solution.q,
            solution.lengths,
            solution.in_valid_range,
            solution.in_range_of_motion,
        )
        assert solution.converged or not (
            solution.in_valid_range and solution.in_range_of_motion
        ), solution.message
    run = GloveSimulation(model, SimulationSettings(pressure_time_constant=0.0)).run(
        np.array([p] * STEPS), np.array([effort] * STEPS)
    )
    assert np.all(run.converged | ~(run.in_valid_range & run.in_range_of_motion))


@settings(max_examples=EXAMPLES, **PROPERTY)
@given(layers=layers, joints=patients, fractions=st.tuples(*[st.floats(0.0, 1.0)] * 3))
def test_the_inverse_of_any_angles_in_the_range_holds_them_or_raises(layers, joints, fractions):
    # Angles anywhere in the range of motion: some need suction or a stretch no pressure gives.
    # The inverse then raises ValueError (it never returns a state that does not hold q).
    model = glove(layers, joints)
    low, high = model.range_of_motion
    q = low + np.array(fractions) * (high - low)
    try:
        held = model.hold(q)
    except ValueError as error:
        assert str(error).startswith('hold: '), str(error)  # why: test_an_unholdable_state_...
        return
    assert np.all(np.isfinite(held.pressure)) and np.all(np.isfinite(held.lengths))
    assert_holds(model, q, held.pressure, held.lengths)
    assert_flags(model, q, held.lengths, held.in_valid_range, held.in_range_of_motion)


# -- regressions: what the exploration found -----------------------------------------------------

# hold once started its Newton on the bottom strains from eps = 0 only; between there and the
# root (eps_MCP = 0.20-0.25) the MCP strain balance g(eps) has a positive local minimum (g > 0,
# g' = 0 at eps_MCP = 0.08-0.15) where Newton stalled, so hold raised although the forward solve
# reaches these states inside the validated range and the range of motion.
FOLDED_STATES = [
    ('stroke_moderate', 0.0, (100e3, 0.0, 90e3)),
    ('stroke_moderate', 0.1, (80e3, 0.0, 90e3)),
    ('stroke_severe', 1e-3, (100e3, 0.0, 80e3)),
]
"""(preset, E_L of the MCP segment in N, p in Pa): PIP and DIP inextensible."""


@pytest.mark.parametrize(('name', 'layer', 'p'), FOLDED_STATES)
def test_the_folded_states_are_model_states(name, layer, p):
    model = preset_glove(name, (layer, math.inf, math.inf))
    solution = model.solve(p)
    assert_converged(model, solution)
    assert solution.in_valid_range and solution.in_range_of_motion
    estimate = model.estimate(solution.q, p)  # the estimator finds these strains
    assert_same_forces(estimate.forces, solution.forces, 1.0)


@pytest.mark.parametrize(('name', 'layer', 'p'), FOLDED_STATES)
def test_hold_finds_the_strains_of_a_state_the_forward_solve_reaches(name, layer, p):
    model = preset_glove(name, (layer, math.inf, math.inf))
    solution = model.solve(p)
    held = model.hold(solution.q)
    assert_holds(model, solution.q, held.pressure, held.lengths)


# -- where the inverse leaves the model, and where it cannot answer ---------------------------


def test_the_inverse_flags_a_root_outside_the_validated_model():
    # Issue 27: with no layer stiffness, holding the DIP at 60 degrees is a true balance but it
    # stretches the DIP's bottom face about 3.3 times and asks for megapascals; hold said none
    # of that.
    model = glove((0.0, 0.0, 0.0))
    q = np.radians([10.0, 10.0, 60.0])
    held = model.hold(q)
    assert_holds(model, q, held.pressure, held.lengths)  # a true root, not a solver failure
    valid, moving = expected_flags(model.params, q, held.lengths)
    assert not valid and moving  # outside the validated stretch, inside the range of motion
    assert held.pressure.max() > SUPPLY  # beyond the supply
    assert not held.in_valid_range and held.in_range_of_motion and not held.within_supply
    assert held.status == OUTSIDE_STRETCH + BEYOND_SUPPLY, held.message
    assert 'stretch' in held.message and 'supply' in held.message, held.message
    with pytest.warns(OutsideModelWarning, match=r'^pressure_for: .*stretch.*supply'):
        np.testing.assert_array_equal(model.pressure_for(q), held.pressure)

    estimate = model.estimate(q, held.pressure)  # the estimator at that state says as much
    assert not estimate.in_valid_range and estimate.status == OUTSIDE_STRETCH, estimate.message
    with pytest.warns(OutsideModelWarning, match=r'^estimate_forces: .*stretch'):
        model.estimate_forces(q, held.pressure)
    rows = model.estimate_batch(np.stack([q, np.zeros(3)]), np.stack([held.pressure, np.zeros(3)]))
    np.testing.assert_array_equal(rows.status, [OUTSIDE_STRETCH, 0])
    with pytest.warns(OutsideModelWarning, match=r'^estimate_forces_batch: .*stretch'):
        model.estimate_forces_batch(np.stack([q, np.zeros(3)]), np.stack([held.pressure] * 2))


def test_the_inverse_inside_the_model_says_so_and_does_not_warn():
    model = glove((0.0, math.inf, 100.0))
    solution = model.solve([30e3, 20e3, 10e3])
    assert_converged(model, solution)
    assert expected_flags(model.params, solution.q, solution.lengths) == (True, True)
    held = model.hold(solution.q)
    assert held.status == 0 and held.message == 'inside the validated model'
    with warnings.catch_warnings():
        warnings.simplefilter('error', OutsideModelWarning)
        model.pressure_for(solution.q)
        model.estimate_forces(solution.q, held.pressure)


UNHOLDABLE_DIP = -0.5
"""A DIP angle that no bottom-face strain of an E_L = 0 DIP segment holds, rad: bent backwards
half a radian (its range of motion starts at 0)."""
OUT_OF_BALANCE = re.compile(
    r'^hold: no bottom-face strain balances the segments at q = .* \(the (?P<segment>\w+) '
    r'segment stopped (?P<left>\S+) N·m out of balance at bottom stretch (?P<bottom>\S+), '
    r'top (?P<top>\S+): (inside|outside) the validated range'
)
"""What hold's ValueError must say: the segment, the balance it was left out by and its
stretches."""


def dip_strain_balance(model, q, strain):
    """The DIP's strain balance g(ε) of hold, N·m, from the forward residual alone.

    (12.4) and ℓ̂ × (12.5) of the DIP (residual rows 2 and 5) are linear in its pressure: the
    pressure that zeroes (12.4) at bottom strain ``strain``, put into (12.5), leaves g. A root of
    g is a state hold must find.
    """
    lengths = model.constants.arc_lengths * np.array([1.0, 1.0, 1.0 + strain])
    vented = model.residual(q, np.zeros(3), lengths=lengths)
    slope = model.residual(q, np.array([0.0, 0.0, 1.0]), lengths=lengths) - vented  # per Pa
    pressure = -vented[2] / slope[2]
    return vented[5] + slope[5] * pressure


def test_an_unholdable_state_raises_naming_segment_residual_and_stretches():
    model = glove((math.inf, math.inf, 0.0))
    q = np.array([0.0, 0.0, UNHOLDABLE_DIP])
    # Why no strain holds it: over the material law's whole domain (every fibre stretch >=
    # MIN_STRETCH, up to a bottom stretch of 100) the balance never changes sign. This fails if
    # the state ever becomes holdable.
    per_angle = model.constants.strain_per_angle[2]
    lowest = max(MIN_STRETCH, MIN_STRETCH - UNHOLDABLE_DIP * per_angle) - 1.0
    strains = lowest + np.geomspace(1e-9, 100.0, 400)
    balance = np.array([dip_strain_balance(model, q, strain) for strain in strains])
    assert np.all(balance < 0.0), strains[balance >= 0.0]

    with pytest.raises(ValueError) as raised:
        model.hold(q)
    said = OUT_OF_BALANCE.match(str(raised.value))
    assert said, str(raised.value)
    assert said['segment'] == 'dip'
    bottom, top = float(said['bottom']), float(said['top'])
    assert top == pytest.approx(
        bottom + UNHOLDABLE_DIP * dip_height(model) / dip_rest(model), abs=1e-3
    )
    left = dip_strain_balance(model, q, bottom - 1.0)  # the residual it names is the balance's
    assert float(said['left']) == pytest.approx(left, rel=5e-3)
    with pytest.raises(ValueError, match=r'^hold: .*the dip segment'):
        model.pressure_for(q)


def dip_height(model):
    """b + h + r0 + t of the DIP segment, m (the top fibre's height, docs/spec/model.md (12.1))."""
    segment = model.params.exo_digit.segments[2]
    return (
        segment.base_thickness
        + segment.wall_height
        + segment.inner_radius
        + segment.wall_thickness
    )


def dip_rest(model):
    """ℓ̂ of the DIP segment, m."""
    return model.params.exo_digit.segments[2].arc_length
