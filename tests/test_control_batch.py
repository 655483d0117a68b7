"""The controllers and the safety limiter over a batch of gloves (exodigit_model.control).

The reference is the one-glove path, the node's (tests/test_control.py checks it): a batch of
N rows fed different feedback must give, row by row and bit for bit, what N one-glove loops
give. Then the limiter's invariants over random batches, the force feed-forward's compiled rows
against the model's Jacobian, and the two BatchController adapters against what they stand for:
BuiltInMode against one-glove CommandLoops on one-glove simulations (as
tests/test_control_patients.py runs them), PolicyController against GloveEnv.
"""

import numpy as np
import pytest
from exodigit_model.control import (
    LIMIT_KINDS,
    BatchController,
    BuiltInMode,
    CommandLoop,
    Feedback,
    ForceController,
    Hold,
    PositionController,
    SafetyLimiter,
    SafetyLimits,
    Sine,
    Staircase,
)
from exodigit_model.gym.env import GloveEnv, PolicyController, observe
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp

from exodigit_model import (
    GloveModel,
    GloveSimulation,
    SimulationSettings,
    load_params,
    params_from_dict,
    patient_file,
)

NOMINAL = GloveModel(load_params())
LIMITS = SafetyLimits(60e3, 100e3, (-0.1, -0.1, -0.1), (1.5, 1.7, 1.4), 5.0)
ROWS = 7
STEPS = 120
DT = 0.01
#: Per-row hold pressures, Pa: some above max_pressure, one negative.
HOLD = np.linspace([0.0, 10e3, 20e3], [80e3, 70e3, -5e3], ROWS)
MODES = {
    'staircase': lambda count, row: Staircase(10e3, 70e3, 0.15),
    'sine': lambda count, row: Sine(0.0, 70e3, 0.6),
    'hold': lambda count, row: Hold(HOLD if row is None else HOLD[row]),
    'position': lambda count, row: PositionController(
        NOMINAL, [0.4, 0.3, 0.2], 5e4, 3e5, count=count
    ),
    'force': lambda count, row: ForceController(NOMINAL, [0.1, 0.2, 0.3], 5e4, 5e5, count=count),
}


def feedback_sequence(seed):
    """Per step the feedback of ROWS gloves: row r leaves the limits more often as r grows.

    Angles wander inside the range of motion or, with probability r/ROWS/2, beyond it; forces
    likewise beyond 5 N. Steps 40-44 have no angles and 70-72 no forces (whole batch).
    """
    rng = np.random.default_rng(seed)
    hostile = (np.arange(ROWS) / ROWS / 2.0)[:, None]
    sequence = []
    for step in range(STEPS):
        inside = rng.uniform([-0.05, -0.05, -0.05], [1.3, 1.5, 1.2], (ROWS, 3))
        wild = rng.uniform(-0.4, 2.0, (ROWS, 3))
        angles = np.where(rng.random((ROWS, 3)) < hostile / 3, wild, inside)
        forces = rng.uniform(-4.0, 4.0, (ROWS, 3))
        forces = np.where(rng.random((ROWS, 3)) < hostile / 3, 1.6 * forces, forces)
        sequence.append(
            Feedback(
                None if 40 <= step < 45 else angles,
                None if 70 <= step < 73 else forces,
            )
        )
    return sequence


def row_of(feedback, row):
    pick = lambda value: None if value is None else value[row]  # noqa: E731
    return Feedback(pick(feedback.angles), pick(feedback.forces))


def assert_row_equals_one_glove(batch, one, row):
    """A batch's row equals a one-glove command (or Limited), bit for bit, reasons alike."""
    assert batch.pressure[row].tobytes() == one.pressure.tobytes()
    np.testing.assert_array_equal(batch.acted[row], one.acted)
    assert list(one.reasons) == [
        kind for kind, on in zip(LIMIT_KINDS, one.acted, strict=True) if on
    ]


# -- a batch equals its gloves one by one ----------------------------------------------------


@pytest.mark.parametrize('mode', MODES)
@pytest.mark.parametrize('seed', [1, 2])
def test_every_mode_gives_each_row_what_one_glove_gets(mode, seed):
    make = MODES[mode]
    batch = CommandLoop(make(ROWS, None), SafetyLimiter(LIMITS, count=ROWS))
    gloves = [CommandLoop(make(None, row), SafetyLimiter(LIMITS)) for row in range(ROWS)]
    acted = np.zeros(len(LIMIT_KINDS), int)
    for step, feedback in enumerate(feedback_sequence(seed)):
        t = step * DT
        command = batch.command(t, DT, feedback)
        assert command.pressure.shape == (ROWS, 3)
        for row, glove in enumerate(gloves):
            one = glove.command(t, DT, row_of(feedback, row))
            assert_row_equals_one_glove(command, one, row)
            assert one.missing == command.missing
            if batch.controller.closed_loop:
                assert batch.controller.integral[row].tobytes() == (
                    glove.controller.integral.tobytes()
                )
        acted += command.acted.sum(axis=0)
    # the sequence exercises the limits the mode can meet (non-finite needs a hostile request)
    assert (acted[1:] > 0).all(), dict(zip(LIMIT_KINDS, acted.tolist(), strict=True))


hostile_rows = hnp.arrays(np.float64, (ROWS, 3), elements=st.floats(-1e5, 2e5) | st.just(np.nan))


@settings(max_examples=40, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), requests=st.lists(hostile_rows, min_size=1, max_size=8))
def test_the_limiter_gives_each_row_what_one_glove_gets(seed, requests):
    rng = np.random.default_rng(seed)
    batch = SafetyLimiter(LIMITS, count=ROWS)
    gloves = [SafetyLimiter(LIMITS) for _ in range(ROWS)]
    for desired in requests:
        dt = float(rng.choice([0.0, 0.01, 0.2]))
        angles = rng.uniform(-0.3, 1.9, (ROWS, 3))
        forces = rng.uniform(-6.0, 6.0, (ROWS, 3))
        limited = batch.apply(desired, dt, angles, forces)
        for row, glove in enumerate(gloves):
            one = glove.apply(desired[row], dt, angles[row], forces[row])
            assert_row_equals_one_glove(limited, one, row)


# -- the limiter's invariants on random batches ----------------------------------------------


@settings(max_examples=100, deadline=None)
@given(
    requests=st.lists(
        hnp.arrays(np.float64, (5, 3), elements=st.floats(allow_nan=True, allow_infinity=True)),
        min_size=1,
        max_size=15,
    ),
    dt=st.floats(0.0, 0.1),
    angles=hnp.arrays(np.float64, (5, 3), elements=st.floats(-0.5, 2.0)),
)
def test_every_row_stays_in_range_rate_and_finite(requests, dt, angles):
    limiter = SafetyLimiter(LIMITS, count=5)
    last = np.zeros((5, 3))
    for request in requests:
        sent = limiter.apply(request, dt, angles).pressure
        assert np.isfinite(sent).all()
        assert (sent >= 0.0).all() and (sent <= LIMITS.max_pressure).all()
        assert (np.abs(sent - last) <= LIMITS.max_pressure_rate * dt * (1 + 1e-12)).all()
        last = sent


def test_a_row_that_backs_off_ramps_down_alone_then_stays_capped_alone():
    limiter = SafetyLimiter(LIMITS, count=3)
    limiter.last = np.full((3, 3), 40e3)
    inside = np.full((3, 3), 0.5)
    outside = inside.copy()
    outside[1, 0] = 1.6  # glove 1's mcp beyond 1.5 rad
    for step in range(1, 6):
        out = limiter.apply(np.full(3, 45e3), 0.01, angles=outside)
        np.testing.assert_array_equal(out.pressure[1], [40e3 - step * 1e3] * 3)
        np.testing.assert_array_equal(out.pressure[[0, 2]], np.full((2, 3), 40e3 + step * 1e3))
        np.testing.assert_array_equal(out.acted[:, LIMIT_KINDS.index('back-off')], [0, 1, 0])
    assert out.reasons['back-off'].endswith('on 1 of 3 gloves')
    for _ in range(3):  # back inside, every glove asks for more: only glove 1 is capped
        out = limiter.apply(np.full(3, 50e3), 0.01, angles=inside)
        np.testing.assert_array_equal(out.pressure[1], [35e3] * 3)
        np.testing.assert_array_equal(out.acted[:, LIMIT_KINDS.index('ceiling')], [0, 1, 0])
    np.testing.assert_array_equal(out.pressure[[0, 2]], np.full((2, 3), 48e3))
    assert out.reasons == {
        'ceiling': 'capped after a back-off on 1 of 3 gloves',
        'rate': 'rate limited to 100000 Pa/s on 2 of 3 gloves',
    }


def test_shapes_that_do_not_fit_the_batch_are_refused_naming_them():
    limiter = SafetyLimiter(LIMITS, count=4)
    with pytest.raises(ValueError, match=r'angles must have shape \(4, 3\)'):
        limiter.apply(np.zeros(3), 0.01, angles=np.zeros((3, 3)))
    with pytest.raises(ValueError, match=r'desired must have shape \(4, 3\)'):
        limiter.apply(np.zeros((2, 3)), 0.01)
    loop = CommandLoop(PositionController(NOMINAL, [0.4, 0.3, 0.2], 1.0, 1.0), limiter)
    with pytest.raises(ValueError, match='integrator must have shape'):
        loop.command(0.0, 0.01, Feedback(np.zeros((4, 3))))
    for count in (0, -2, 1.5, True):
        with pytest.raises(ValueError, match='count'):
            SafetyLimiter(LIMITS, count=count)


# -- the force mode's feed-forward -----------------------------------------------------------


EXTENSIBLE = GloveModel(
    params_from_dict(
        {'exo_digit': {'segments': [{'layer_axial_stiffness': k} for k in (0.0, 50.0, 20.0)]}}
    )
)


@pytest.mark.parametrize('model', [NOMINAL, EXTENSIBLE], ids=['nominal', 'extensible'])
def test_the_robot_side_torque_is_the_transposed_contact_jacobian_times_the_forces(model):
    rng = np.random.default_rng(4)
    angles = rng.uniform(-0.3, 2.0, (500, 3))
    angles[:5] = 0.0  # the series branch of the kinematics
    forces = rng.uniform(-5.0, 5.0, (500, 3))
    rows = model.robot_contact_torque(angles, forces)
    for q, f, row in zip(angles, forces, rows, strict=True):
        # numpy's product may round in another order (BLAS): a few ulp, not bit for bit
        np.testing.assert_allclose(
            row, model.contact_jacobians(q)[0].T @ f, rtol=1e-13, atol=1e-15
        )
        # one glove is a row of a batch: the same kernel, bit for bit
        assert row.tobytes() == model.robot_contact_torque(q, f).tobytes()


# -- the BatchController adapters ------------------------------------------------------------

PATIENT = GloveModel(load_params(patient_file('stroke_moderate')))
SESSION = 150
#: Voluntary effort of each simulated patient, N·m: makes every glove's state its own.
EFFORTS = np.linspace(-0.03, 0.04, 4)[:, None] * np.array([1.0, 0.8, 0.5])


def one_glove_session(controller, effort):
    """A CommandLoop on one simulated glove with the estimator's forces, as
    tests/test_control_patients.py runs it."""
    simulation = GloveSimulation(PATIENT, SimulationSettings())
    loop = CommandLoop(controller, SafetyLimiter(LIMITS))
    state, commands = simulation.state, []
    for _ in range(SESSION):
        forces = NOMINAL.estimate_forces(state.q_measured, state.pressure_measured)
        command = loop.command(state.t, simulation.period, Feedback(state.q_measured, forces))
        state = simulation.step(command.pressure, effort)
        commands.append(command.pressure)
    return np.array(commands)


@pytest.mark.parametrize('mode', ['sine', 'position', 'force'])
def test_a_built_in_mode_commands_each_glove_of_a_batch_as_the_node_commands_one(mode):
    count = len(EFFORTS)
    controller = BuiltInMode(MODES[mode](None, None), LIMITS, estimator=NOMINAL)
    assert isinstance(controller, BatchController)
    simulation = GloveSimulation(PATIENT, SimulationSettings(), count=count)
    controller.reset(count)
    state, commands = simulation.state, []
    for _ in range(SESSION):
        commands.append(controller.command(state.t, simulation.period, state))
        state = simulation.step(commands[-1], EFFORTS)
    assert controller.last.acted.shape == (count, len(LIMIT_KINDS))
    commands = np.array(commands)
    for row, effort in enumerate(EFFORTS):
        alone = one_glove_session(MODES[mode](None, None), effort)
        assert commands[:, row].tobytes() == alone.tobytes()
    assert len({commands[:, row].tobytes() for row in range(count)}) > 1  # the gloves differ


def test_a_built_in_mode_starts_afresh_at_every_reset():
    controller = BuiltInMode(MODES['position'](None, None), LIMITS)
    simulation = GloveSimulation(PATIENT, SimulationSettings(), count=3)
    sessions = []
    for count in (3, 3):
        controller.reset(count)
        state, commands = simulation.reset(), []
        for _ in range(50):
            commands.append(controller.command(state.t, simulation.period, state))
            state = simulation.step(commands[-1])
        sessions.append(np.array(commands))
    assert sessions[0].tobytes() == sessions[1].tobytes()
    with pytest.raises(ValueError, match=r'feedback.angles must have shape \(3, 3\)'):
        controller.command(0.0, 0.01, GloveSimulation(count=2).state)


def test_the_force_mode_needs_an_estimator():
    with pytest.raises(ValueError, match='estimator'):
        BuiltInMode(MODES['force'](None, None), LIMITS)


#: Per-glove offsets of the test policy, Pa: the last two gloves run into the limits.
OFFSETS = np.array([[0.0, 0.0, 0.0], [8e3, -4e3, 2e3], [45e3, 45e3, 45e3], [-30e3, 0.0, 9e4]])


def base_policy(observations):
    """A policy acting on each row alone: toward the target, against the measured angle."""
    rows = observations.astype(float)
    return 15e3 + 6e4 * rows[:, 9:12] - 2e4 * rows[:, 0:3] + 0.1 * rows[:, 6:9]


def scaled_policy(observations, scale):
    """base_policy in Pa; normalized: p / 30 kPa − 1 (the same Pa where the range is 60 kPa)."""
    pressures = base_policy(observations)
    return pressures if scale == 'physical' else pressures / 30e3 - 1.0


@pytest.mark.parametrize('scale', ['physical', 'normalized'])
@pytest.mark.parametrize('safety', [LIMITS, None], ids=['limited', 'unlimited'])
def test_a_policy_commands_each_glove_of_a_batch_as_glove_env_commands_one(safety, scale):
    count = len(OFFSETS)
    offsets = OFFSETS if scale == 'physical' else OFFSETS / 30e3
    env = GloveEnv(NOMINAL, safety=safety, episode_steps=SESSION, action_scale=scale)
    controller = PolicyController(lambda obs: scaled_policy(obs, scale) + offsets, env)
    assert isinstance(controller, BatchController)
    simulation = GloveSimulation(NOMINAL, env.settings, count=count)
    controller.reset(count)
    state, states = simulation.state, []
    for _ in range(SESSION):
        state = simulation.step(controller.command(state.t, simulation.period, state))
        states.append(state)
    limited = 0
    for row, offset in enumerate(offsets):
        glove = GloveEnv(NOMINAL, safety=safety, episode_steps=SESSION, action_scale=scale)
        observation, _ = glove.reset(seed=0)
        for state in states:
            action = scaled_policy(observation[None], scale)[0] + offset
            observation, _, _, _, info = glove.step(action)
            assert state.command[row].tobytes() == info['command'].tobytes()
            assert state.q[row].tobytes() == info['q'].tobytes()
            limited += bool(info['safety'])
        target = glove.unwrapped._next_target if glove.observe_target else None
        np.testing.assert_array_equal(
            observe(state, env.observation_space, target)[0][row], observation
        )
    assert (limited > 0) == (safety is not None)


def test_a_policy_that_does_not_answer_every_glove_is_refused():
    env = GloveEnv(NOMINAL)
    controller = PolicyController(lambda obs: np.zeros((2, 3)), env)
    controller.reset(3)
    with pytest.raises(ValueError, match=r'action must have shape \(3, 3\)'):
        controller.command(0.0, 0.01, GloveSimulation(count=3).state)
    with pytest.raises(ValueError, match='policy'):
        PolicyController('not a policy', env)
