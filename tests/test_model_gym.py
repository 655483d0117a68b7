"""The Gymnasium environment (exodigit_model.gym.env): API, seeding, spaces, reward, episodes.

Expectations are computed without the environment: observations by a plain GloveSimulation
with the same settings and seed, the default target and reward from their documented formulas
(docs/spec/model.md §13 for the stepper), reachability by the model's exact inverse.
"""

import math
import re
import subprocess
import sys
import warnings
from dataclasses import replace

import gymnasium
import numpy as np
import pytest
from exodigit_model.gym.env import DEFAULT_SAFETY, ENV_ID, NODE_SAFETY, GloveEnv
from gymnasium.utils.env_checker import check_env

from exodigit_model import (
    GloveModel,
    GloveSimulation,
    GloveState,
    SimulationSettings,
    load_params,
    params_from_dict,
)

MODEL = GloveModel(load_params())
NOISY = {'angle_noise_std': 1e-3, 'pressure_noise_std': 200.0}
#: Relative tolerance of two float64 evaluations of one formula (rounding only).
EXACT = 1e-12
#: Absolute floor of reward comparisons, rad² (a squared error of ~3e-8 rad).
REWARD_FLOOR = 1e-15
#: Largest angle error of a feedforward through the exact inverse, rad.
ANGLE_TOLERANCE = 1e-9
#: Actions in Pa, as most tests here give them.
PHYSICAL = {'action_scale': 'physical'}


def documented_target(t, pressure=50e3, period=4.0):
    """q*(t) = peak·(1 − cos(2πt/T))/2, peak = the model's angles at half the 100 kPa supply."""
    peak = MODEL.solve([pressure] * 3).q
    return peak * (1.0 - np.cos(2.0 * np.pi * t / period)) / 2.0


def actions(steps, seed=0, peak=60e3):
    return np.random.default_rng(seed).uniform(0.0, peak, (steps, 3))


def run_episode(env, seed, commands):
    observations = [env.reset(seed=seed)[0]]
    observations += [env.step(command)[0] for command in commands]
    return np.array(observations)


# -- the Gymnasium API ---------------------------------------------------------------------


@pytest.mark.parametrize('made', [True, False], ids=['gymnasium.make', 'noisy GloveEnv'])
def test_check_env_passes_without_warnings(made):
    if made:
        env = gymnasium.make(ENV_ID).unwrapped  # a spec, so the close check runs too
    else:
        env = GloveEnv(settings=SimulationSettings(**NOISY))
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter('always')
        check_env(env, skip_render_check=not made)
    assert [str(w.message) for w in caught] == []
    assert isinstance(env, GloveEnv)


def test_check_env_of_physical_actions_only_recommends_normalizing_them():
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter('always')
        check_env(GloveEnv(**PHYSICAL), skip_render_check=True)
    assert len(caught) == 1 and 'symmetric and normalized space' in str(caught[0].message)


def test_importing_the_model_does_not_import_gymnasium():
    code = (
        'import sys, exodigit_model, exodigit_model.stepping.simulation; '
        "sys.exit(1 if 'gymnasium' in sys.modules else 0)"
    )
    result = subprocess.run([sys.executable, '-c', code], capture_output=True, text=True)
    assert result.returncode == 0, result.stdout + result.stderr


def test_make_passes_options_to_the_environment():
    env = gymnasium.make(ENV_ID, episode_steps=3, observe_target=False)
    env.reset(seed=0)
    outcomes = [env.step(np.zeros(3, np.float32))[3] for _ in range(3)]
    assert outcomes == [False, False, True]
    assert env.observation_space.shape == (9,)


# -- seeding -------------------------------------------------------------------------------


def test_equal_seeds_give_identical_episodes_and_different_seeds_differ():
    commands = actions(150)
    env = GloveEnv(settings=SimulationSettings(**NOISY), **PHYSICAL)
    first = run_episode(env, 5, commands)
    again = run_episode(GloveEnv(settings=SimulationSettings(**NOISY), **PHYSICAL), 5, commands)
    other = run_episode(env, 6, commands)
    np.testing.assert_array_equal(first, again)
    assert not np.array_equal(first[1:, 0:3], other[1:, 0:3])  # angle noise
    assert not np.array_equal(first[1:, 6:9], other[1:, 6:9])  # pressure noise
    np.testing.assert_array_equal(first[:, 3:6], other[:, 3:6])  # q̇ is of the true state


def test_unseeded_resets_follow_the_last_seed():
    commands = actions(20)

    def two_episodes():
        env = GloveEnv(settings=SimulationSettings(**NOISY), **PHYSICAL)
        first = run_episode(env, 9, commands)
        env.reset()
        second = np.array([env.step(command)[0] for command in commands])
        return first, second, env.noise_seed

    first_a, second_a, seed_a = two_episodes()
    first_b, second_b, seed_b = two_episodes()
    np.testing.assert_array_equal(first_a, first_b)
    np.testing.assert_array_equal(second_a, second_b)
    assert seed_a == seed_b != 9
    assert not np.array_equal(first_a[1:], second_a)


def test_observations_equal_a_plain_simulation_with_the_same_seed():
    settings = SimulationSettings(rate_hz=50.0, pressure_time_constant=0.08, **NOISY)
    env = GloveEnv(MODEL, settings=settings, safety=None, **PHYSICAL)
    plain = GloveSimulation(MODEL, SimulationSettings(50.0, 0.08, 100e3, 1e-3, 200.0, seed=21))

    def expected(state, k):
        parts = [state.q_measured, state.qdot, state.pressure_measured]
        return np.concatenate([*parts, documented_target((k + 1) / 50.0)]).astype(np.float32)

    observation, info = env.reset(seed=21)
    np.testing.assert_array_equal(observation[:9], expected(plain.state, 0)[:9])
    for k, command in enumerate(actions(120, seed=4), start=1):
        observation, _, terminated, _, info = env.step(command)
        state = plain.step(command)
        want = expected(state, k)
        np.testing.assert_array_equal(observation[:9], want[:9])
        np.testing.assert_allclose(observation[9:], want[9:], rtol=1e-6, atol=1e-9)
        np.testing.assert_array_equal(info['q'], state.q)
        np.testing.assert_array_equal(info['pressure'], state.pressure)
        assert observation.dtype == np.float32 and observation in env.observation_space
        assert not terminated and info['t'] == state.t and info['noise_seed'] == 21


def test_a_params_file_gives_the_model_it_describes(tmp_path):
    path = tmp_path / 'stiff.yaml'
    path.write_text('finger:\n  joints:\n    - {stiffness: 0.30}\n    - {}\n    - {}\n')
    ideal = SimulationSettings(pressure_time_constant=0.0)
    plain = GloveSimulation(GloveModel(load_params(path)), ideal)
    env = GloveEnv(params=path, settings=ideal, safety=None, **PHYSICAL)
    env.reset(seed=0)
    for command in actions(10):
        observation = env.step(command)[0]
        np.testing.assert_array_equal(
            observation[:3], plain.step(command).q_measured.astype(np.float32)
        )
    assert not np.array_equal(env.state.q, MODEL.solve(env.state.pressure).q)


# -- spaces --------------------------------------------------------------------------------


@pytest.mark.parametrize(
    ('supply', 'safety', 'top'),
    [
        (100e3, None, 100e3),
        (80e3, None, 80e3),
        (100e3, DEFAULT_SAFETY, 60e3),
        (50e3, NODE_SAFETY, 50e3),
    ],
)
def test_the_physical_action_space_is_the_range_the_limiter_and_supply_allow_in_pa(
    supply, safety, top
):
    settings = SimulationSettings(max_supply_pressure=supply)
    env = GloveEnv(settings=settings, safety=safety, **PHYSICAL)
    space = env.action_space
    normalized = GloveEnv(settings=settings, safety=safety)
    assert space == env.physical_action_space == normalized.physical_action_space
    assert isinstance(space, gymnasium.spaces.Box) and space.shape == (3,)
    assert space.dtype == np.float32
    np.testing.assert_array_equal(space.low, np.zeros(3))
    np.testing.assert_array_equal(space.high, np.full(3, top))
    observation, _ = env.reset(seed=0)
    assert env.observation_space.shape == (12,) and observation.shape == (12,)
    assert env.observation_space.dtype == np.float32


def test_commands_beyond_the_supply_are_clipped_as_the_plant_clips_them():
    settings = SimulationSettings(pressure_time_constant=0.0)
    env = GloveEnv(settings=settings, safety=None, **PHYSICAL)
    env.reset(seed=0)
    _, _, _, _, info = env.step([150e3, -1e3, 20e3])
    assert info['saturated']
    np.testing.assert_array_equal(info['command'], [100e3, 0.0, 20e3])
    np.testing.assert_array_equal(info['pressure'], [100e3, 0.0, 20e3])


def test_an_observation_beyond_its_bounds_is_clipped_and_reported():
    env = GloveEnv(target=lambda t: [4.0, 0.0, -4.0])  # beyond ±π
    observation, info = env.reset(seed=0)
    assert info['observation_clipped'] and observation in env.observation_space
    np.testing.assert_array_equal(observation[9:], np.float32([math.pi, 0.0, -math.pi]))
    assert not GloveEnv().reset(seed=0)[1]['observation_clipped']


# -- the safety limiter -------------------------------------------------------------------


def test_the_node_limits_stand_between_the_agent_and_the_chambers():
    # Ideal chambers: the pressure is the command, which may rise by at most
    # max_pressure_rate·Δt = 100 kPa/s · 10 ms = 1 kPa a step, up to max_pressure = 60 kPa.
    settings = SimulationSettings(pressure_time_constant=0.0)
    env = GloveEnv(settings=settings, safety=NODE_SAFETY, **PHYSICAL)
    env.reset(seed=0)
    for k in range(1, 71):
        _, _, _, _, info = env.step([100e3, 100e3, 100e3])
        expected = min(k * 1e3, 60e3)
        np.testing.assert_allclose(info['pressure'], [expected] * 3, rtol=1e-12)
        assert ('rate' in info['safety']) == (k < 60) and 'pressure' in info['safety']
    _, _, _, _, info = env.step([30e3, 30e3, 30e3])
    np.testing.assert_allclose(info['pressure'], [59e3] * 3, rtol=1e-12)
    assert 'pressure' not in info['safety']


def test_leaving_the_range_of_motion_ramps_the_command_down_then_caps_it():
    # The default glove at 60 kPa bends MCP to about 0.6 rad: a range ending at 0.3 rad is left
    # on the way up. Outside, each step lowers the command by the rate limit (1 kPa); back
    # inside, it stays capped although the agent keeps asking for 60 kPa.
    limits = replace(NODE_SAFETY, joint_upper=(0.3, 1.75, 1.4))
    settings = SimulationSettings(pressure_time_constant=0.0)
    env = GloveEnv(settings=settings, safety=limits, **PHYSICAL)
    env.reset(seed=0)
    commands, outside = [0.0], []
    for _ in range(150):
        outside.append(bool(env.state.q_measured[0] > 0.3))
        info = env.step([60e3, 60e3, 60e3])[4]
        assert ('back-off' in info['safety']) == outside[-1]
        commands.append(info['command'][0])
    steps = np.diff(commands)
    first_out = outside.index(True)
    assert np.all(steps[:first_out] == pytest.approx(1e3))  # rising at the rate limit
    np.testing.assert_allclose(steps[np.array(outside)], -1e3, rtol=1e-9)  # backing off
    back_in = first_out + outside[first_out:].index(False)
    assert np.all(steps[back_in:] <= 1e-9)  # never rising again
    assert 0.25 < env.state.q[0] <= 0.3 + 0.01  # settled at the edge of the range


# -- reward, target, episodes --------------------------------------------------------------


def test_the_default_reward_is_minus_the_squared_angle_error_to_the_documented_target():
    env = GloveEnv(MODEL, settings=SimulationSettings(**NOISY), safety=None, **PHYSICAL)
    plain = GloveSimulation(MODEL)  # the true state does not depend on the noise
    previous, _ = env.reset(seed=2)
    for command in actions(200, seed=8, peak=90e3):
        observation, reward, _, _, info = env.step(command)
        state = plain.step(command)
        target = documented_target(state.t)
        expected = -float(np.sum((state.q - target) ** 2))
        assert reward == pytest.approx(expected, rel=EXACT, abs=REWARD_FLOOR)
        np.testing.assert_allclose(info['target'], target, rtol=EXACT, atol=1e-15)
        np.testing.assert_array_equal(previous[9:], info['target'].astype(np.float32))
        previous = observation


def test_the_default_target_peaks_at_the_model_at_half_the_supply_and_is_reachable():
    # The angles docs/gym.md prints are pinned in tests/test_docs_figures.py.
    env = GloveEnv()
    np.testing.assert_allclose(env.target(2.0), MODEL.solve([50e3] * 3).q, rtol=0, atol=1e-12)
    for t in np.linspace(0.0, 4.0, 81):
        pressure = MODEL.pressure_for(env.target(t))
        assert np.all(pressure >= -1e-6) and np.all(pressure <= 100e3)


def test_a_feedforward_through_the_exact_inverse_tracks_the_default_target_perfectly():
    ideal = SimulationSettings(pressure_time_constant=0.0)
    env = GloveEnv(settings=ideal, episode_steps=400, **PHYSICAL)
    env.reset(seed=0)
    for k in range(1, 401):
        command = MODEL.pressure_for(documented_target(k / 100.0))
        _, reward, terminated, _, info = env.step(command)
        np.testing.assert_allclose(info['q'], info['target'], rtol=0, atol=ANGLE_TOLERANCE)
        assert -reward <= 3 * ANGLE_TOLERANCE**2 and not terminated


def test_the_episode_truncates_after_the_documented_number_of_steps():
    env = GloveEnv()
    env.reset(seed=0)
    truncated = [env.step(np.zeros(3))[3] for _ in range(400)]
    assert truncated == [False] * 399 + [True]
    short = GloveEnv(episode_steps=7)
    short.reset(seed=0)
    assert [short.step(np.zeros(3))[3] for _ in range(7)] == [False] * 6 + [True]


def test_a_custom_target_and_reward_are_used():
    calls = []

    def target(t):
        return [0.1 * t, 0.2, 0.0]

    def reward(state, desired, action):
        calls.append((state, desired, action))
        return 7.0 - float(action.sum())

    env = GloveEnv(target=target, reward=reward, **PHYSICAL)
    observation, _ = env.reset(seed=0)
    np.testing.assert_array_equal(observation[9:], np.float32([0.001, 0.2, 0.0]))
    for k, command in enumerate(actions(5), start=1):
        observation, value, _, _, info = env.step(command)
        state, desired, action = calls[-1]
        assert isinstance(state, GloveState) and state is env.state and state.step == k
        np.testing.assert_allclose(desired, [0.1 * k / 100.0, 0.2, 0.0], rtol=EXACT)
        np.testing.assert_array_equal(action, command)
        assert value == 7.0 - float(command.sum())
        np.testing.assert_array_equal(info['target'], desired)
        np.testing.assert_allclose(observation[9:], [0.1 * (k + 1) / 100.0, 0.2, 0.0], rtol=1e-6)
    assert len(calls) == 5


def test_a_failed_solve_terminates_the_episode_keeping_the_last_good_state():
    # A silicone of C1 = 1 Pa holds 5 kPa on the finger but not 100 kPa (test_model_solver).
    soft = GloveModel(params_from_dict({'material': {'c1': 1.0, 'c2': 0.0, 'c3': 0.0}}))
    settings = SimulationSettings(pressure_time_constant=0.0)
    env = GloveEnv(soft, settings=settings, target=lambda t: np.zeros(3), safety=None, **PHYSICAL)
    env.reset(seed=0)
    good, _, terminated, _, _ = env.step([5e3, 5e3, 5e3])
    assert not terminated
    failed, _, terminated, truncated, info = env.step([100e3, 100e3, 100e3])
    assert terminated and not truncated and not info['converged']
    np.testing.assert_array_equal(failed[:3], good[:3])


# -- bad input -----------------------------------------------------------------------------


@pytest.mark.parametrize(
    ('kwargs', 'name'),
    [
        ({'episode_steps': 0}, 'episode_steps'),
        ({'episode_steps': 2.5}, 'episode_steps'),
        ({'episode_steps': True}, 'episode_steps'),
        ({'target': 'sine'}, 'target'),
        ({'reward': 3.0}, 'reward'),
        ({'settings': {'rate_hz': 100.0}}, 'settings'),
        ({'model': 'default'}, 'model'),
        ({'model': MODEL, 'params': 'x.yaml'}, 'model and params'),
        ({'params': 42}, 'params'),
        ({'observe_target': 1}, 'observe_target'),
        ({'safety': {'max_pressure': 50e3}}, 'safety'),
        ({'settings': SimulationSettings(max_supply_pressure=1e10)}, 'model'),
        ({'action_scale': 'pascal'}, 'action_scale'),
    ],
    ids=lambda value: re.sub(' at 0x[0-9a-f]+', '', repr(value)),  # the same in every run
)
def test_bad_arguments_are_refused_naming_them(kwargs, name):
    with pytest.raises(ValueError, match=name):
        GloveEnv(**kwargs)


@pytest.mark.parametrize('action', [[1.0, 2.0], [np.nan, 0.0, 0.0], 'abc'], ids=repr)
def test_a_bad_action_is_refused_naming_it(action):
    env = GloveEnv()
    env.reset(seed=0)
    with pytest.raises(ValueError, match='action'):
        env.step(action)


def test_bad_targets_rewards_options_and_order_are_refused():
    with pytest.raises(ValueError, match='target'):
        GloveEnv(target=lambda t: [0.0, 0.0]).reset(seed=0)
    env = GloveEnv(reward=lambda state, target, action: math.nan)
    env.reset(seed=0)
    with pytest.raises(ValueError, match='reward'):
        env.step(np.zeros(3))
    with pytest.raises(ValueError, match='options'):
        GloveEnv().reset(options={'start': 1})
    with pytest.raises(gymnasium.error.ResetNeeded):
        GloveEnv().step(np.zeros(3))
