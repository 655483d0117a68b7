"""GloveEnv behind valves (actuation='valves', docs/spec/model.md §14): API, spaces, physics.

Observations are checked against a plain valve-mode GloveSimulation with the same seed; the air
an open inlet lets in during one step against the bounds ISO 6358-3 (14.3), written out in
tests/test_model_pneumatics.py, puts on it (the flow falls as the chamber fills); the air masses
against the gas law (14.2); closed valves against conservation of mass.
"""

import warnings
from dataclasses import replace

import gymnasium
import numpy as np
import pytest
from exodigit_model.control import SafetyLimits
from exodigit_model.gym.env import VALVE_PRESSURE_MARGIN, GloveEnv
from exodigit_model.physics.pneumatics import ATMOSPHERIC_PRESSURE, GAS_CONSTANT
from gymnasium.utils.env_checker import check_env
from test_model_pneumatics import iso_flow

from exodigit_model import GloveModel, GloveSimulation, SimulationSettings, params_from_dict

NOISY = SimulationSettings(angle_noise_std=1e-3, pressure_noise_std=200.0)
#: Relative tolerance of results that are exact up to rounding.
ROUND_OFF = 1e-12
#: Relative slack of the one-step air budget: the step's integration error, below the spread
#: of the bounds (the flow falls by 0.7 % to 9 % over the step as the inlets open wider).
INTEGRATION = 1e-3
#: The defaults' valves (default_params.yaml, pneumatics): C, m³/(s·Pa), and b.
CONDUCTANCE, CRITICAL = 5e-10, 0.3
T = 293.15
#: Openings in [0, 1], as most tests here give them.
PHYSICAL = {'action_scale': 'physical'}


def openings(steps, count=None, seed=0):
    """Random openings in [0, 1]: (steps, 6), or (steps, count, 6)."""
    shape = (steps, 6) if count is None else (steps, count, 6)
    return np.random.default_rng(seed).uniform(0.0, 1.0, shape)


@pytest.mark.parametrize('made', [True, False], ids=['gymnasium.make', 'noisy GloveEnv'])
def test_check_env_passes_behind_valves_without_warnings(made):
    if made:
        env = gymnasium.make('exodigit/Glove-v0', actuation='valves').unwrapped
    else:
        env = GloveEnv(settings=NOISY, actuation='valves')
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter('always')
        check_env(env, skip_render_check=not made)
    assert [str(w.message) for w in caught] == []
    assert env.safety is None and env.actuation == 'valves'


def test_the_action_is_six_openings_and_the_pressure_bounds_are_the_pneumatic_supplys():
    model = GloveModel(params_from_dict({'pneumatics': {'supply_pressure': 80e3}}))
    env = GloveEnv(model, actuation='valves')
    space, physical = env.action_space, env.physical_action_space
    assert space.shape == physical.shape == (6,) and space.dtype == physical.dtype == np.float32
    np.testing.assert_array_equal(space.low, -np.ones(6))
    np.testing.assert_array_equal(space.high, np.ones(6))
    np.testing.assert_array_equal(physical.low, np.zeros(6))
    np.testing.assert_array_equal(physical.high, np.ones(6))
    assert GloveEnv(model, actuation='valves', **PHYSICAL).action_space == physical
    np.testing.assert_array_equal(
        env.observation_space.high[6:9], [80e3 + VALVE_PRESSURE_MARGIN] * 3
    )
    np.testing.assert_array_equal(env.observation_space.low[6:9], [-VALVE_PRESSURE_MARGIN] * 3)
    assert env.observation_space.shape == (12,)
    np.testing.assert_array_equal(GloveEnv().observation_space.low[6:9], np.zeros(3))


def test_a_valve_episode_is_a_plain_valve_simulation_with_the_same_seed():
    env = GloveEnv(settings=NOISY, actuation='valves', **PHYSICAL)
    plain = GloveSimulation(env.model, replace(NOISY, seed=7), actuation='valves')
    observation, info = env.reset(seed=7)
    np.testing.assert_array_equal(info['mass'], plain.state.mass)
    clipped = 0
    for command in openings(150, seed=3):
        observation, _, terminated, _, info = env.step(command.tolist())
        state = plain.step(command)
        want = np.concatenate([state.q_measured, state.qdot, state.pressure_measured])
        np.testing.assert_array_equal(observation[:9], want.astype(np.float32))
        for key in ('q', 'pressure', 'command', 'mass', 'volume'):
            np.testing.assert_array_equal(info[key], getattr(state, key))
        assert not terminated and observation in env.observation_space
        clipped += info['observation_clipped']
    assert clipped == 0


def test_one_step_of_open_inlets_lets_in_the_air_iso_6358_allows():
    env = GloveEnv(actuation='valves', **PHYSICAL)
    _, info = env.reset(seed=0)
    before = info['mass']
    inlets = np.array([0.2, 0.5, 1.0])
    _, _, _, _, info = env.step(np.concatenate([inlets, np.zeros(3)]))
    absolute = info['pressure'] + ATMOSPHERIC_PRESSURE
    # the gas law (14.2) at the reported volume
    np.testing.assert_allclose(
        info['mass'], absolute * info['volume'] / (GAS_CONSTANT * T), rtol=ROUND_OFF
    )
    supply = env.settings.max_supply_pressure + ATMOSPHERIC_PRESSURE
    dt = 1.0 / env.settings.rate_hz
    # the chamber fills monotonically from P_atm to P_1, so Q(P_s, P) lies between its values
    # at the two ends: the air that came in lies between Δt times those
    most = [
        dt * u * iso_flow(CONDUCTANCE, CRITICAL, supply, ATMOSPHERIC_PRESSURE, T) for u in inlets
    ]
    least = [
        dt * u * iso_flow(CONDUCTANCE, CRITICAL, supply, p, T)
        for u, p in zip(inlets, absolute, strict=True)
    ]
    gained = info['mass'] - before
    assert np.all(gained > np.array(least) * (1 - INTEGRATION)), (gained, least)
    assert np.all(gained < np.array(most) * (1 + INTEGRATION)), (gained, most)
    assert least[2] < 0.95 * most[2]  # the open inlet's bounds are not one number


def test_closed_valves_keep_the_air_and_open_outlets_vent_to_rest():
    env = GloveEnv(actuation='valves', **PHYSICAL)
    _, rest = env.reset(seed=0)
    for _ in range(5):
        env.step([0.4, 0.4, 0.4, 0.0, 0.0, 0.0])
    filled = env.state.mass.copy()
    assert np.all(env.state.pressure > 20e3)
    for _ in range(20):
        _, _, _, _, info = env.step(np.zeros(6))
        np.testing.assert_allclose(info['mass'], filled, rtol=ROUND_OFF)
    for _ in range(300):
        _, _, _, _, info = env.step([0.0, 0.0, 0.0, 1.0, 1.0, 1.0])
    np.testing.assert_allclose(info['pressure'], 0.0, atol=1.0)
    np.testing.assert_allclose(info['q'], rest['q'], atol=1e-4)


def test_openings_outside_zero_one_are_clipped_and_reported():
    env = GloveEnv(actuation='valves', **PHYSICAL)
    env.reset(seed=0)
    _, _, _, _, info = env.step([1.5, -0.2, 0.5, 0.0, 2.0, 0.0])
    assert info['saturated']
    np.testing.assert_array_equal(info['command'], [1.0, 0.0, 0.5, 0.0, 1.0, 0.0])


def test_normalized_openings_map_linearly_onto_zero_one():
    env = GloveEnv(actuation='valves')
    env.reset(seed=0)
    _, _, _, _, info = env.step([-1.0, 0.0, 1.0, -0.5, 0.5, 3.0])
    assert info['saturated']  # 3 is opening 2, clipped
    np.testing.assert_array_equal(info['command'], [0.0, 0.5, 1.0, 0.25, 0.75, 1.0])


@pytest.mark.parametrize(
    ('kwargs', 'name'),
    [
        ({'actuation': 'solenoids'}, 'actuation'),
        ({'actuation': 'valves', 'safety': SafetyLimits(max_pressure=50e3)}, 'safety'),
    ],
    ids=['unknown actuation', 'limits behind valves'],
)
def test_bad_arguments_are_refused_naming_them(kwargs, name):
    with pytest.raises(ValueError, match=name):
        GloveEnv(**kwargs)


@pytest.mark.parametrize('action', [[0.5, 0.5, 0.5], [np.nan] * 6, 'abc'], ids=repr)
def test_a_bad_action_is_refused_naming_it(action):
    env = GloveEnv(actuation='valves')
    env.reset(seed=0)
    with pytest.raises(ValueError, match='action'):
        env.step(action)
