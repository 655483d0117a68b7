"""The glove as RL libraries take it (issue 38): normalized actions, the default limits, every
registered id made by Gymnasium and Stable-Baselines3, the SB3 adapter of the vector env.

Expectations come from outside the code under test: normalized actions against a physical
environment fed the documented line low + (a + 1)/2·(high − low); the adapter and the
one-glove population environment against plain GloveEnvs on the same patients, stepped and reset
where Stable-Baselines3's own DummyVecEnv would. Tests that need Stable-Baselines3 (the ``rl``
extra) are skipped, with the reason, where it is not installed; the adapter's protocol is tested
without it.
"""

import subprocess
import sys
import warnings
from pathlib import Path

import gymnasium
import numpy as np
import pytest
from exodigit_model.control import SafetyLimits
from exodigit_model.gym.env import (
    DEFAULT_SAFETY,
    ENV_ID,
    NODE_SAFETY,
    OPEN_PRESSURE_RATE,
    GloveEnv,
)
from exodigit_model.gym.sb3 import PopulationVecEnv, _sb3_class, sb3_vec_env
from exodigit_model.gym.vector import VECTOR_ENV_ID, GlovePatientEnv, GloveVectorEnv
from gymnasium.utils.env_checker import check_env
from gymnasium.vector import AutoresetMode
from test_model_gym_vector import failing, glove_env

from exodigit_model import SimulationSettings

IDEAL = SimulationSettings(pressure_time_constant=0.0)
SAME_STEP = {'autoreset_mode': AutoresetMode.SAME_STEP}
NO_SB3 = 'Stable-Baselines3 is not installed (the rl extra: pip install "./exodigit_model[rl]")'


def registered_ids():
    return sorted(key for key in gymnasium.registry if key.startswith('exodigit/'))


def sb3():
    return pytest.importorskip('stable_baselines3', reason=NO_SB3)


def normalized(steps, width=3, seed=0):
    return np.random.default_rng(seed).uniform(-1.0, 1.0, (steps, width))


# -- normalized actions ---------------------------------------------------------------------


@pytest.mark.parametrize(
    ('safety', 'top'),
    [(DEFAULT_SAFETY, 60e3), (SafetyLimits(50e3, OPEN_PRESSURE_RATE), 50e3), (None, 100e3)],
)
def test_normalized_actions_are_the_physical_range_on_a_line(safety, top):
    env = GloveEnv(settings=IDEAL, safety=safety)
    physical = GloveEnv(settings=IDEAL, safety=safety, action_scale='physical')
    assert env.action_space == gymnasium.spaces.Box(-1.0, 1.0, (3,), np.float32)
    first, _ = env.reset(seed=0)
    np.testing.assert_array_equal(first, physical.reset(seed=0)[0])
    for action in normalized(60):
        got = env.step(action)
        expected = physical.step((action + 1.0) / 2.0 * top)
        np.testing.assert_allclose(got[0], expected[0], rtol=1e-6)
        assert got[1] == pytest.approx(expected[1], rel=1e-9, abs=1e-15)
    for action, pressure in ((-1.0, 0.0), (1.0, top), (0.0, top / 2)):
        env.reset(seed=0)
        np.testing.assert_array_equal(env.step(np.full(3, action))[4]['command'], pressure)


def test_the_reward_gets_the_physical_action():
    seen = []
    env = GloveEnv(reward=lambda state, target, action: seen.append(action) or 0.0)
    env.reset(seed=0)
    env.step([-1.0, 0.5, 1.0])
    np.testing.assert_allclose(seen[0], [0.0, 45e3, 60e3], rtol=1e-12)


def test_the_vector_env_maps_actions_as_each_glove_env_does():
    envs = GloveVectorEnv(3, episode_steps=4)
    physical = GloveVectorEnv(3, episode_steps=4, action_scale='physical')
    actions = np.random.default_rng(1).uniform(-1.0, 1.0, (9, 3, 3))
    envs.reset(seed=2)
    physical.reset(seed=2)
    for action in actions:
        got, expected = envs.step(action), physical.step((action + 1.0) / 2.0 * 60e3)
        np.testing.assert_allclose(got[0], expected[0], rtol=1e-6)
        np.testing.assert_allclose(got[1], expected[1], rtol=1e-9, atol=1e-15)


# -- the limiter ----------------------------------------------------------------------------


def test_random_actions_reach_the_glove_by_default_and_not_behind_the_node_rate_limit():
    def limited_steps(safety):
        env, count = GloveEnv(safety=safety), 0
        env.reset(seed=0)
        env.action_space.seed(0)
        for _ in range(400):
            count += bool(env.step(env.action_space.sample())[4]['safety'])
        return count

    assert limited_steps(DEFAULT_SAFETY) == 0
    assert limited_steps(NODE_SAFETY) > 390  # the rate limit: 1 kPa a step at 100 Hz
    assert DEFAULT_SAFETY.max_pressure_rate * 0.01 >= DEFAULT_SAFETY.max_pressure


# -- every id, made by Gymnasium and Stable-Baselines3 ---------------------------------------


def test_both_ids_are_registered_with_entry_points():
    assert registered_ids() == sorted([ENV_ID, VECTOR_ENV_ID])
    for key in registered_ids():
        assert gymnasium.spec(key).entry_point is not None


@pytest.mark.parametrize('actuation', ['regulator', 'valves'])
@pytest.mark.parametrize('key', [ENV_ID, VECTOR_ENV_ID])
def test_gymnasium_check_env_passes_for_every_id_without_warnings(key, actuation):
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter('always')
        check_env(gymnasium.make(key, actuation=actuation).unwrapped)
    assert [str(w.message) for w in caught] == []


@pytest.mark.parametrize('actuation', ['regulator', 'valves'])
@pytest.mark.parametrize('key', [ENV_ID, VECTOR_ENV_ID])
def test_sb3_check_env_passes_for_every_id_without_warnings(key, actuation):
    sb3()
    from stable_baselines3.common.env_checker import check_env as sb3_check_env

    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter('always')
        sb3_check_env(gymnasium.make(key, actuation=actuation), warn=True)
    assert [str(w.message) for w in caught] == []


@pytest.mark.parametrize('key', [ENV_ID, VECTOR_ENV_ID])
def test_sb3_make_vec_env_makes_and_steps_every_id(key):
    sb3()
    from stable_baselines3.common.env_util import make_vec_env

    venv = make_vec_env(key, n_envs=2, seed=3, env_kwargs={'episode_steps': 3})
    observations = venv.reset()
    assert observations.shape == (2, 12) and observations.dtype == np.float32
    for _ in range(3):
        *_, dones, infos = venv.step(np.zeros((2, 3), np.float32))
    assert dones.all() and all(info['episode']['l'] == 3 for info in infos)


@pytest.mark.parametrize('key', [ENV_ID, VECTOR_ENV_ID])
def test_cleanrl_style_gymnasium_vector_envs_of_every_id_step(key):
    envs = gymnasium.vector.SyncVectorEnv(
        [lambda: gymnasium.make(key, episode_steps=2) for _ in range(2)]
    )
    envs = gymnasium.wrappers.vector.RecordEpisodeStatistics(envs)
    observations, _ = envs.reset(seed=1)
    assert observations.shape == (2, 12)
    for _ in range(2):
        *_, infos = envs.step(envs.action_space.sample())
    assert infos['_episode'].all() and infos['episode']['l'].tolist() == [2, 2]


# -- one glove on a new patient at every reset ----------------------------------------------


def test_the_patient_env_is_a_glove_env_on_a_new_patient_at_every_reset():
    env = gymnasium.make(VECTOR_ENV_ID, episode_steps=5).unwrapped
    assert isinstance(env, GlovePatientEnv)
    fingers = []
    for episode in range(3):
        observation, _ = env.reset(seed=10 if episode == 0 else None)
        fingers.append(env.finger)
        single = glove_env(env.patients, 0)
        np.testing.assert_array_equal(observation, single.reset(seed=0)[0])
        for action in normalized(5, seed=episode):
            got, expected = env.step(action), single.step(action)
            np.testing.assert_array_equal(got[0], expected[0])
            assert got[1:4] == expected[1:4]
            np.testing.assert_array_equal(got[4]['q'], expected[4]['q'])
            assert got[4]['safety'] == tuple(expected[4]['safety'])
    assert len(set(fingers)) == 3
    again = gymnasium.make(VECTOR_ENV_ID, episode_steps=5).unwrapped
    assert [again.reset(seed=10 if k == 0 else None) and again.finger for k in range(3)] == fingers


def test_the_patient_env_refuses_vector_keywords():
    with pytest.raises(ValueError, match='num_envs'):
        GlovePatientEnv(num_envs=3)


# -- SAME_STEP autoreset and the Stable-Baselines3 adapter ----------------------------------


def assert_adapter_is_a_plain_loop(venv, actions, seed):
    """Step ``venv`` and one GloveEnv per sub-environment as SB3's DummyVecEnv would."""
    envs = venv.envs
    venv.seed(seed)
    observations = venv.reset()
    singles = [glove_env(envs, row) for row in range(envs.num_envs)]
    for row, single in enumerate(singles):
        np.testing.assert_array_equal(observations[row], single.reset(seed=0)[0])
    ends = {'terminated': 0, 'truncated': 0}
    for action in actions:
        venv.step_async(action)
        observations, rewards, dones, infos = venv.step_wait()
        assert len(infos) == envs.num_envs
        for row, single in enumerate(singles):
            observation, reward, terminated, truncated, info = single.step(action[row])
            assert (rewards[row], dones[row]) == (reward, terminated or truncated)
            np.testing.assert_array_equal(infos[row]['q'], info['q'])
            if terminated or truncated:
                ends['terminated' if terminated else 'truncated'] += 1
                np.testing.assert_array_equal(infos[row]['terminal_observation'], observation)
                assert infos[row]['TimeLimit.truncated'] == (truncated and not terminated)
                singles[row] = single = glove_env(envs, row)  # the new patient
                observation, info = single.reset(seed=0)
                np.testing.assert_array_equal(venv.reset_infos[row]['q'], info['q'])
            else:
                assert 'terminal_observation' not in infos[row]
            np.testing.assert_array_equal(observations[row], observation)
    return ends


# Random full-range pressures flex some patient past their range of motion, which the limiter's
# force estimate warns of; the adapter must step through it as the plain loop does.
@pytest.mark.filterwarnings('ignore::exodigit_model.physics.validity.OutsideModelWarning')
def test_the_adapter_steps_as_a_plain_loop_of_glove_envs_through_resets():
    venv = PopulationVecEnv(GloveVectorEnv(3, episode_steps=4, **SAME_STEP))
    ends = assert_adapter_is_a_plain_loop(venv, normalized(11 * 3, seed=5).reshape(11, 3, 3), 1)
    assert ends == {'terminated': 0, 'truncated': 6}


def test_the_adapter_tells_a_failed_solve_from_a_time_limit():
    envs, actions = failing(**SAME_STEP)  # row 0 fails at step 2, resets at once
    ends = assert_adapter_is_a_plain_loop(PopulationVecEnv(envs), actions, 4)
    assert ends == {'terminated': 1, 'truncated': 3}


def test_same_step_and_next_step_draw_the_same_patients_and_episodes():
    actions = normalized(12 * 2, seed=3).reshape(12, 2, 3)
    same, following = (
        GloveVectorEnv(2, episode_steps=3, **SAME_STEP),
        GloveVectorEnv(2, episode_steps=3),
    )
    same.reset(seed=8)
    following.reset(seed=8)
    k = 0
    for action in actions:
        got = same.step(action)
        expected = following.step(action)
        if got[2].any() or got[3].any():
            np.testing.assert_array_equal(got[4]['final_obs'][0], expected[0][0])
            assert got[4]['_final_obs'].all() and got[4]['final_info']['t'].tolist() == [0.03] * 2
            expected = following.step(action)  # NEXT_STEP resets on the next step
            k += 1
        np.testing.assert_array_equal(got[0], expected[0])
        assert same.fingers == following.fingers
    assert k == 4  # episodes of 3 steps end at steps 3, 6, 9 and 12


def test_the_adapter_reads_the_definition_and_refuses_what_a_batch_cannot_do():
    venv = PopulationVecEnv(GloveVectorEnv(2, **SAME_STEP))
    assert venv.get_attr('episode_steps') == [400, 400]
    assert venv.get_attr('render_mode', indices=1) == [None]
    assert venv.env_is_wrapped(gymnasium.Wrapper) == [False, False]
    with pytest.raises(AttributeError):
        venv.get_attr('no_such_attribute')
    with pytest.raises(ValueError, match='set_attr'):
        venv.set_attr('episode_steps', 3)
    with pytest.raises(ValueError, match='env_method'):
        venv.env_method('reset')
    with pytest.raises(ValueError, match='step_async'):
        venv.step_wait()
    with pytest.raises(ValueError, match='SAME_STEP'):
        PopulationVecEnv(GloveVectorEnv(2))
    with pytest.raises(ValueError, match='GloveVectorEnv'):
        PopulationVecEnv(GloveEnv())
    with pytest.raises(ValueError, match='autoreset_mode'):
        GloveVectorEnv(2, autoreset_mode=AutoresetMode.DISABLED)


def test_sb3_takes_the_adapter_and_learns_a_few_steps():
    sb3()
    from stable_baselines3 import PPO
    from stable_baselines3.common.vec_env import VecEnv, VecMonitor, VecNormalize

    venv = sb3_vec_env(4, episode_steps=8)
    assert isinstance(venv, VecEnv) and isinstance(venv, PopulationVecEnv)
    assert sb3_vec_env(GloveVectorEnv(2, **SAME_STEP)).num_envs == 2
    wrapped = VecNormalize(VecMonitor(venv))
    agent = PPO('MlpPolicy', wrapped, n_steps=16, batch_size=32, n_epochs=1, seed=0)
    agent.learn(64)
    assert agent.num_timesteps == 64 and len(agent.ep_info_buffer) == 8
    with pytest.raises(ValueError, match='population'):
        sb3_vec_env(GloveVectorEnv(2, **SAME_STEP), population='healthy')


def test_the_adapter_without_sb3_says_how_to_install_it(monkeypatch):
    monkeypatch.setitem(sys.modules, 'stable_baselines3', None)
    monkeypatch.setitem(sys.modules, 'stable_baselines3.common.vec_env', None)
    _sb3_class.cache_clear()
    try:
        with pytest.raises(ImportError, match=r'exodigit_model\[rl\]'):
            sb3_vec_env(2)
    finally:
        _sb3_class.cache_clear()


def test_importing_the_adapter_does_not_import_sb3():
    code = (
        'import sys, exodigit_model.gym.sb3; '
        "sys.exit(1 if 'stable_baselines3' in sys.modules else 0)"
    )
    assert subprocess.run([sys.executable, '-c', code]).returncode == 0


def test_the_ppo_example_prints_and_draws_its_learning_curve(tmp_path):
    sb3()
    pytest.importorskip('matplotlib', reason='the example draws with matplotlib (rl extra)')
    plot = tmp_path / 'curve.png'
    example = Path(__file__).resolve().parents[1] / 'examples' / 'ppo_glove.py'
    arguments = ['--timesteps', '256', '--envs', '2', '--n-steps', '64', '--batch-size', '64']
    arguments += ['--evaluations', '2', '--patients', '2', '--plot', str(plot)]
    result = subprocess.run(
        [sys.executable, str(example), *arguments], capture_output=True, text=True, timeout=600
    )
    assert result.returncode == 0, result.stderr
    rows = [line.split() for line in result.stdout.splitlines() if line[:10].strip().isdigit()]
    assert [row[0] for row in rows] == ['0', '128', '256']
    assert 'env-steps/s' in result.stdout and plot.read_bytes().startswith(b'\x89PNG')
