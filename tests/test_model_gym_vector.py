"""GloveVectorEnv (exodigit_model.gym.vector): patients per reset, seeding, autoreset, the API.

The independent answer for every sub-environment is a one-glove GloveEnv on that sub-
environment's patient, fed the same actions and reset where the vector environment says it
resets; patients' ranges are the population's own bounds.
"""

import warnings
from dataclasses import replace

import gymnasium
import numpy as np
import pytest
from exodigit_model.gym.env import GloveEnv
from exodigit_model.gym.vector import INFO_KEYS, VECTOR_ENV_ID, GloveVectorEnv
from exodigit_model.physics.populations import PATIENT_FIELDS
from exodigit_model.trials import load_population
from gymnasium.utils.passive_env_checker import check_obs, check_space, data_shares_objects
from gymnasium.vector import AutoresetMode

from exodigit_model import GloveModel, SimulationSettings, params_from_dict

NOISY = SimulationSettings(angle_noise_std=1e-3, pressure_noise_std=200.0)
#: A silicone of C1 = 1 Pa: on a patient's finger it holds 5 kPa but not 1 MPa (measured).
SOFT = GloveModel(params_from_dict({'material': {'c1': 1.0, 'c2': 0.0, 'c3': 0.0}}))
#: No lag and a supply of 1 MPa, so the soft glove's solve can be made to fail.
STRONG = SimulationSettings(pressure_time_constant=0.0, max_supply_pressure=1e6)


def random_actions(steps, count, seed=0):
    """Random normalized actions, (steps, count, 3)."""
    return np.random.default_rng(seed).uniform(-1.0, 1.0, (steps, count, 3))


def run(envs, seed, actions):
    """Everything a run returns, as arrays with a leading step axis (the reset first)."""
    observations, infos = envs.reset(seed=seed)
    record = {'observation': [observations], 'q': [infos['q']], 'finger': [list(envs.fingers)]}
    for key in ('reward', 'terminated', 'truncated'):
        record[key] = []
    for action in actions:
        observation, reward, terminated, truncated, infos = envs.step(action)
        for key, value in zip(
            ('observation', 'reward', 'terminated', 'truncated', 'q'),
            (observation, reward, terminated, truncated, infos['q']),
            strict=True,
        ):
            record[key].append(value)
        record['finger'].append(list(envs.fingers))
    return {
        key: np.array(value, dtype=object if key == 'finger' else None)
        for key, value in record.items()
    }


def glove_env(envs, row, **kwargs):
    """A GloveEnv on sub-environment ``row``'s patient, otherwise ``envs``'s definition."""
    definition = envs.definition
    model = GloveModel(replace(definition.model.params, finger=envs.fingers[row]))
    return GloveEnv(
        model,
        settings=definition.settings,
        episode_steps=definition.episode_steps,
        target=definition.target,
        safety=definition.safety,
        actuation=definition.actuation,
        action_scale=definition.action_scale,
        **kwargs,
    )


def assert_sub_envs_are_glove_envs(envs, actions, seed=0):
    """Step ``envs`` and one GloveEnv per sub-environment, comparing bit for bit."""
    observations, _ = envs.reset(seed=seed)
    singles = [glove_env(envs, row) for row in range(envs.num_envs)]
    for row, single in enumerate(singles):
        np.testing.assert_array_equal(observations[row], single.reset(seed=0)[0])
    ended = np.zeros(envs.num_envs, bool)
    resets = 0
    for action in actions:
        observations, rewards, terminated, truncated, _ = envs.step(action)
        for row in range(envs.num_envs):
            if ended[row]:  # NEXT_STEP: this step reset the row on a new patient
                singles[row] = glove_env(envs, row)
                expected = singles[row].reset(seed=0)[0], 0.0, False, False
                resets += 1
            else:
                expected = singles[row].step(action[row])[:4]
            got = observations[row], rewards[row], terminated[row], truncated[row]
            np.testing.assert_array_equal(got[0], expected[0])
            assert got[1:] == expected[1:], (row, got[1:], expected[1:])
        ended = terminated | truncated
    return resets


# -- each sub-environment is a GloveEnv on its patient ------------------------------------


def test_each_sub_env_steps_as_a_glove_env_on_its_patient_through_autoresets():
    envs = GloveVectorEnv(3, episode_steps=4)
    assert assert_sub_envs_are_glove_envs(envs, random_actions(11, 3)) == 6


def failing(**keywords):
    """Three soft gloves and actions under which row 0's solve fails at step 2 (only)."""
    envs = GloveVectorEnv(
        3,
        population='healthy',
        model=SOFT,
        settings=STRONG,
        safety=None,
        episode_steps=5,
        target=lambda t: np.zeros(3),
        action_scale='physical',
        **keywords,
    )
    actions = np.full((9, 3, 3), 5e3)
    actions[1, 0] = 1e6
    return envs, actions


def test_a_sub_env_whose_solve_fails_resets_alone_and_still_steps_as_a_glove_env():
    envs, actions = failing()  # row 0 fails at step 2, resets at step 3; the others go on
    envs.reset(seed=4)
    *_, terminated, _, _ = envs.step(actions[0])
    _, _, terminated, truncated, _ = envs.step(actions[1])
    assert terminated.tolist() == [True, False, False] and not truncated.any()
    _, rewards, terminated, truncated, infos = envs.step(actions[2])
    assert infos['t'].tolist() == [0.0, 0.03, 0.03] and rewards[0] == 0.0
    # row 0 resets at steps 3 and 9 (truncated 5 steps after its reset), rows 1 and 2 at 6
    assert assert_sub_envs_are_glove_envs(envs, actions, seed=4) == 4
    assert len(envs._cohorts) == 2  # the first cohort left when its last member did


def test_behind_valves_each_sub_env_steps_as_a_valve_glove_env_on_its_patient():
    envs = GloveVectorEnv(3, episode_steps=4, actuation='valves')
    actions = np.random.default_rng(2).uniform(-1.0, 1.0, (11, 3, 6))
    assert assert_sub_envs_are_glove_envs(envs, actions) == 6
    assert envs.single_action_space.shape == (6,) and envs.action_space.shape == (3, 6)
    _, _, _, _, infos = envs.step(actions[0])
    assert set(envs.info_keys) == set(INFO_KEYS) | {'mass', 'volume'} <= set(infos)
    assert infos['mass'].shape == infos['volume'].shape == (3, 3)
    assert infos['command'].shape == (3, 6)
    with pytest.raises(ValueError, match='actions'):
        envs.step(np.zeros((3, 3)))


# -- seeding and patients -------------------------------------------------------------------


def test_reset_with_a_seed_reproduces_episodes_bit_for_bit_and_other_seeds_differ():
    actions = random_actions(12, 4, seed=1)
    make = lambda: GloveVectorEnv(4, settings=NOISY, episode_steps=5)  # noqa: E731
    envs = make()
    first, again, other = run(envs, 7, actions), run(make(), 7, actions), run(envs, 8, actions)
    for key, value in first.items():
        if key == 'finger':
            assert value.tolist() == again[key].tolist()
        else:
            np.testing.assert_array_equal(value, again[key], err_msg=key)
    assert first['finger'][0].tolist() != other['finger'][0].tolist()
    assert not np.array_equal(first['observation'], other['observation'])
    assert first['truncated'][4].all() and first['truncated'].sum() == 2 * 4


def test_patients_differ_between_sub_envs_and_resets_and_stay_in_the_population_ranges():
    population = load_population('stroke_severe')
    envs = GloveVectorEnv(16, population=population, episode_steps=1)
    record = run(envs, 3, np.zeros((4, 16, 3)))
    patients = [finger for fingers in record['finger'][::2] for finger in fingers]
    assert len(set(patients)) == len(patients) == 3 * 16  # resets at steps 0, 2, 4
    for finger in patients:
        for joint, distributions in zip(finger.joints, population.joints, strict=True):
            for key in PATIENT_FIELDS:
                law = distributions[key]
                assert law.low <= getattr(joint, key) <= law.high, (key, getattr(joint, key))
    base = envs.model.params.finger
    assert all(
        [j.link_half_length for j in finger.joints] == [j.link_half_length for j in base.joints]
        for finger in patients
    )


def test_the_patients_of_a_reset_are_the_populations_draw_from_the_env_generator():
    envs = GloveVectorEnv(5, population='healthy')
    envs.reset(seed=11)
    patient_seed = int(np.random.default_rng(11).integers(2**63, size=2)[0])
    expected = load_population('healthy').sample(5, patient_seed, base=envs.model.params.finger)
    assert envs.fingers == list(expected.fingers)


# -- autoreset -------------------------------------------------------------------------------


def test_autoreset_is_next_step_ignoring_the_action_of_a_resetting_sub_env():
    assert GloveVectorEnv.metadata['autoreset_mode'] == AutoresetMode.NEXT_STEP

    def ends(last_action):
        envs = GloveVectorEnv(2, episode_steps=3)
        envs.reset(seed=0)
        steps = [envs.step(np.full((2, 3), -0.3)) for _ in range(3)]
        return steps, envs.step(np.full((2, 3), last_action))

    steps, (observations, rewards, terminated, truncated, infos) = ends(-0.3)
    assert [s[3].tolist() for s in steps] == [[False] * 2, [False] * 2, [True] * 2]
    assert infos['t'].tolist() == [0.0, 0.0] and rewards.tolist() == [0.0, 0.0]
    assert not terminated.any() and not truncated.any()
    np.testing.assert_array_equal(observations[:, 3:9], 0.0)  # at rest: q̇ = 0, vented
    _, (other, *_) = ends(0.8)
    np.testing.assert_array_equal(observations, other)


# -- spaces, data and Gymnasium's own checks -----------------------------------------------


def test_spaces_dtypes_and_infos_follow_the_vector_api():
    envs = GloveVectorEnv(4, observe_target=False)
    single = GloveEnv(observe_target=False)
    assert envs.single_action_space == single.action_space
    assert envs.single_observation_space == single.observation_space
    assert envs.action_space.shape == (4, 3) and envs.observation_space.shape == (4, 9)
    assert envs.action_space.dtype == envs.observation_space.dtype == np.float32
    check_space(envs.single_action_space, 'action', lambda space: None)
    check_space(envs.single_observation_space, 'observation', lambda space: None)
    assert envs.render_mode is None
    previous = envs.reset(seed=0)
    envs.action_space.seed(0)
    for _ in range(3):
        observations, rewards, terminated, truncated, infos = envs.step(envs.action_space.sample())
        assert observations.dtype == np.float32 and observations in envs.observation_space
        check_obs(observations, envs.observation_space, 'step')
        assert rewards.dtype == np.float64 and rewards.shape == (4,)
        assert terminated.dtype == truncated.dtype == bool
        assert set(infos) == set(INFO_KEYS) | {f'_{key}' for key in INFO_KEYS}
        assert infos['safety'].shape == (4, 5) and infos['target'].shape == (4, 3)
        assert not data_shares_objects(previous, (observations, infos))
        previous = observations, infos


def test_make_vec_builds_it_without_warnings_and_wrappers_accept_it():
    with warnings.catch_warnings():
        warnings.simplefilter('error')
        envs = gymnasium.make_vec(VECTOR_ENV_ID, num_envs=3, population='healthy')
    assert isinstance(envs, GloveVectorEnv) and envs.population.name == 'healthy'
    assert envs.spec.kwargs['num_envs'] == 3
    envs = gymnasium.wrappers.vector.RecordEpisodeStatistics(GloveVectorEnv(2, episode_steps=2))
    envs.reset(seed=0)
    *_, infos = envs.step(np.zeros((2, 3)))
    *_, infos = envs.step(np.zeros((2, 3)))
    assert infos['_episode'].all() and infos['episode']['l'].tolist() == [2, 2]


# -- bad input ------------------------------------------------------------------------------


@pytest.mark.parametrize(
    ('kwargs', 'name'),
    [
        ({'num_envs': 0}, 'num_envs'),
        ({'num_envs': 2.0}, 'num_envs'),
        ({'num_envs': True}, 'num_envs'),
        ({'num_envs': 2, 'population': 'no_such_population'}, 'no_such_population'),
        ({'num_envs': 2, 'population': 42}, 'population'),
        ({'num_envs': 2, 'episode_steps': 0}, 'episode_steps'),
        ({'num_envs': 2, 'safety': 'off'}, 'safety'),
    ],
    ids=repr,
)
def test_bad_arguments_are_refused_naming_them(kwargs, name):
    with pytest.raises(ValueError, match=name):
        GloveVectorEnv(**kwargs)


@pytest.mark.parametrize(
    'actions', [np.zeros((3, 3)), np.zeros(3), [[np.nan, 0, 0], [0, 0, 0]], 'abc'], ids=repr
)
def test_bad_actions_are_refused_naming_them(actions):
    envs = GloveVectorEnv(2)
    envs.reset(seed=0)
    with pytest.raises(ValueError, match='actions'):
        envs.step(actions)


def test_bad_resets_rewards_and_order_are_refused():
    with pytest.raises(gymnasium.error.ResetNeeded):
        GloveVectorEnv(2).step(np.zeros((2, 3)))
    with pytest.raises(ValueError, match='options'):
        GloveVectorEnv(2).reset(options={'reset_mask': np.ones(2, bool)})
    with pytest.raises(ValueError, match='seed'):
        GloveVectorEnv(2).reset(seed=1.5)
    envs = GloveVectorEnv(2, reward=lambda state, target, actions: 0.0)
    envs.reset(seed=0)
    with pytest.raises(ValueError, match='reward'):
        envs.step(np.zeros((2, 3)))
