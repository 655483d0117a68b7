"""The trial runner (issue 17, items 2 and 4): shards on the batch stepper, merged and judged.

Small populations and sessions of a fraction of a second keep this file fast; what is checked
does not depend on the size: a population of one against a direct GloveSimulation + controller
loop, bit for bit; shard sizes that do not change any patient's metrics; seeds; the rules on a
known-unsafe and a known-gentle controller; user controllers and policies by module:attribute;
refusals.
"""

import doctest
import pickle
from dataclasses import replace

import numpy as np
import pytest
from exodigit_model.control import LIMIT_PARAMETERS, BuiltInMode, SafetyLimits, Sine
from exodigit_model.trials import (
    METRICS,
    ControllerSpec,
    Engine,
    LocalEngine,
    MetricAccumulator,
    PatientMetrics,
    TrialSpec,
    load_population,
    record_patient,
    run_shard,
    run_trial,
    shard_bounds,
    shard_seeds,
)
from exodigit_model.trials import spec as spec_module
from exodigit_model.trials import trial as trial_module
from exodigit_model.trials.controllers import COMMON_PARAMETERS, MODE_PARAMETERS
from exodigit_nodes.nodes.catalog import PRESSURE_COMMAND_NODE

from exodigit_model import GloveModel, GloveSimulation, SimulationSettings, load_params

SHORT = {'duration': 0.4}
"""A 40-step session at 100 Hz."""

NOISY = SimulationSettings(angle_noise_std=2e-3, pressure_noise_std=200.0)


def spec(**changes):
    fields = {'population': 'stroke_moderate', 'patients': 7, 'protocol_parameters': SHORT}
    return TrialSpec(**(fields | changes))


def assert_same(a: PatientMetrics, b: PatientMetrics):
    assert (a.steps, a.settings) == (b.steps, b.settings)
    for metric in METRICS:
        np.testing.assert_array_equal(a.values[metric.name], b.values[metric.name], metric.name)


def test_a_population_of_one_is_a_direct_simulation_bit_for_bit():
    trial = spec(patients=1, seed=3, simulation=NOISY, controller=ControllerSpec('mode', 'sine'))
    result = run_trial(trial)

    finger = load_population('stroke_moderate').sample(1, 3).fingers[0]
    model = GloveModel(replace(load_params(), finger=finger))
    noise_seed, _ = shard_seeds(trial, 0)
    protocol = trial.session()
    simulation = GloveSimulation(model, replace(NOISY, seed=noise_seed), count=1)
    controller = BuiltInMode(Sine(0.0, 40e3, 4.0), SafetyLimits())
    controller.reset(1)
    metrics = MetricAccumulator(1, trial.metric_settings())
    state, angles = simulation.state, []
    for t in protocol.times():
        state = simulation.step(controller.command(state.t, simulation.period, state))
        assert state.t == t
        metrics.update(
            q=state.q,
            target=protocol.targets(t),
            forces=state.forces,
            pressure=state.pressure,
            limited=controller.last.acted.any(axis=1),
            solver_warning=~state.converged,
            outside_model=~(state.in_valid_range & state.in_range_of_motion),
        )
        angles.append(state.q[0])
    assert_same(result.metrics, metrics.result())
    assert result.metrics.values['rom_rad'].min() > 0.0  # the glove moved the finger
    np.testing.assert_array_equal(record_patient(trial, 0).q, angles)


def test_shard_sizes_do_not_change_any_patients_metrics():
    trials = [
        spec(shard_size=size, controller=ControllerSpec('mode', 'position')) for size in (1, 3, 7)
    ]
    results = [run_trial(trial).metrics for trial in trials]
    assert [len(shard_bounds(trial)) for trial in trials] == [7, 3, 1]
    assert shard_bounds(trials[1]) == [(0, 3), (3, 6), (6, 7)]
    for other in results[1:]:
        assert_same(results[0], other)
    assert len(set(results[0].values['peak_force_n'][:, 1])) == 7  # seven different patients


def test_a_shard_is_its_rows_of_the_whole_trial():
    trial = spec(shard_size=3)
    whole = run_trial(spec(shard_size=7)).metrics
    part = run_shard(trial, 1)
    for metric in METRICS:
        np.testing.assert_array_equal(part.values[metric.name], whole.values[metric.name][3:6])


def test_same_seed_same_results_another_seed_other_patients():
    first, again, other = (run_trial(spec(seed=seed, simulation=NOISY)) for seed in (5, 5, 6))
    assert_same(first.metrics, again.metrics)
    assert first.summary == again.summary
    assert not np.array_equal(first.metrics.values['rom_rad'], other.metrics.values['rom_rad'])
    np.testing.assert_array_equal(
        first.patients.arrays['stiffness'],
        load_population('stroke_moderate').sample(7, 5).arrays['stiffness'],
    )


@pytest.mark.parametrize(
    ('factory', 'status'),
    [('trial_controllers:full_supply', 1), ('trial_controllers:gentle', 0)],
)
def test_full_supply_fails_a_force_rule_a_gentle_controller_passes(factory, status):
    trial = spec(population='healthy', controller=ControllerSpec('controller', factory))
    result = run_trial(
        trial, rules=['peak_force_n <= 0.5 for 100%', 'solver_warning_steps <= 0 for 100%']
    )
    assert result.status == status
    assert result.passed is (status == 0)
    assert [outcome.passed for outcome in result.rules] == [status == 0, True]
    assert result.message.startswith('failed' if status else 'passed')
    if status:
        worst = int(np.argmax(result.metrics.column('peak_force_n')))
        assert result.worst_patient() == result.rules[0].worst_patient == worst


# Fingers that differ only in how far the MCP may flex (rom_max, rad); no stop torque, so a
# glove that flexes the MCP past it goes on (the defaults of default_params.yaml otherwise).
LOW_MCP_RANGE = """
joints:
  - {rom_max: {kind: uniform, low: 0.1, high: 0.8}, rom_torque: 0.0}
  - {}
  - {}
"""


@pytest.mark.parametrize(
    ('population', 'pressure', 'way_out'),
    [
        ('low_mcp_range', 5e3, None),  # the MCP flexes about 0.05 rad in the 0.4 s
        ('low_mcp_range', 50e3, 'range of motion'),  # about 0.55 rad
        ('stroke_severe', 100e3, 'stretch'),  # flexed fingers flexed on: top fibres past 1.5
    ],
)
def test_steps_outside_the_model_are_counted_from_each_patients_angles(
    population, pressure, way_out, tmp_path
):
    if population == 'low_mcp_range':
        path = tmp_path / 'low_mcp_range.yaml'
        path.write_text(LOW_MCP_RANGE)
        population = str(path)
    controller = ControllerSpec(
        'controller', 'trial_controllers:full_supply', {'pressure': pressure}
    )
    trial = spec(population=population, controller=controller)
    result = run_trial(trial)
    # Independent of the stepper's flags: each recorded step's angles against the patient's
    # range of motion, and the fibre stretches of those angles (12.1) against the validated
    # range; the default glove is inextensible, so the stretches follow from q alone.
    glove = trial.glove_params()
    assert not any(segment.extensible for segment in glove.exo_digit.segments)
    model = GloveModel(glove)
    low, high = (result.patients.arrays[key] for key in ('rom_min', 'rom_max'))
    ways = {'stretch': [], 'range of motion': []}
    for patient in range(trial.patients):
        q = record_patient(trial, patient).q
        ways['stretch'].append(~model.in_valid_range(q))
        ways['range of motion'].append(((q < low[patient]) | (q > high[patient])).any(axis=1))
    stretched, past = (np.array(steps) for steps in ways.values())  # (patient, step)
    np.testing.assert_array_equal(
        result.metrics.values['outside_model_steps'], np.count_nonzero(stretched | past, axis=1)
    )
    for name, steps in ways.items():
        left = np.any(steps, axis=1)
        if name == way_out:  # some patients left the model this way, some did not
            assert 0 < np.count_nonzero(left) < len(left), name
        else:
            assert not left.any(), name


def test_a_user_controller_reports_its_limiter_per_glove():
    controller = ControllerSpec('controller', 'trial_controllers:flagging', {'pressure': 15e3})
    metrics = run_trial(spec(controller=controller)).metrics
    np.testing.assert_array_equal(metrics.values['limiter_steps'], [40, 0, 40, 0, 40, 0, 40])
    assert metrics.values['peak_pressure_pa'].max() <= 15e3


def test_a_gymnasium_policy_by_its_factory(tmp_path):
    module = tmp_path / 'my_policy.py'
    module.write_text(
        'import numpy as np\n'
        'def make(*, env, action):\n'
        '    assert env.observation_space.shape == (12,)\n'
        '    return lambda observations: np.full((len(observations), 3), action)\n'
    )
    # 0 is the middle of the normalized range [-1, 1]: 30 kPa of [0, 60 kPa]
    controller = ControllerSpec('policy', f'{module}:make', {'action': 0.0})
    result = run_trial(spec(patients=3, controller=controller))
    pressures = result.metrics.values['peak_pressure_pa']
    assert np.all((pressures > 20e3) & (pressures <= 30e3))


def test_the_engine_contract():
    trial = spec(shard_size=3)
    done = []
    parts = LocalEngine().map(trial, [2, 0], lambda index, part: done.append((index, len(part))))
    assert isinstance(LocalEngine(), Engine)
    assert done == [(2, 1), (0, 3)]
    assert_same(parts[1], run_shard(trial, 0))
    with pytest.raises(IndexError, match='shards 0 … 2'):
        run_shard(trial, 3)


def test_a_spec_pickles_and_runs_the_same():
    trial = spec(controller=ControllerSpec('mode', 'hold', {'hold_pressure': [1e4, 2e4, 3e4]}))
    copy = pickle.loads(pickle.dumps(trial))
    assert copy == trial
    assert copy.controller.parameters == (('hold_pressure', (1e4, 2e4, 3e4)),)
    assert_same(run_shard(copy, 0), run_shard(trial, 0))


def test_mode_parameters_are_the_nodes():
    defaults = PRESSURE_COMMAND_NODE.table.defaults()
    for parameters in (*MODE_PARAMETERS.values(), COMMON_PARAMETERS):
        for name, (default, _) in parameters.items():
            if name != 'estimate_forces':
                assert defaults[name] == default, name
    assert set(LIMIT_PARAMETERS) <= set(defaults)


@pytest.mark.parametrize(
    ('changes', 'message'),
    [
        ({'patients': 0}, 'patients = 0: must be a whole number >= 1'),
        ({'seed': -1}, 'seed = -1'),
        ({'shard_size': 2.5}, 'shard_size = 2.5'),
        ({'population': 'nobody'}, 'cannot read population file'),
        ({'protocol': 'jog'}, "protocol 'jog': unknown"),
        ({'protocol_parameters': {'duration': 0.005}}, 'whole number of steps'),
        ({'protocol_parameters': {'tempo': 1}}, "unknown parameter 'tempo'"),
        ({'params_file': 'no/such.yaml'}, 'no/such.yaml'),
        ({'force_limit': 0.0}, 'force_limit = 0.0: must be > 0'),
        ({'simulation': SimulationSettings(rate_hz=50.0)}, 'the protocol sets the rate'),
        ({'controller': 'sine'}, 'must be a ControllerSpec'),
    ],
)
def test_bad_specs_are_refused_naming_the_field(changes, message):
    with pytest.raises(ValueError, match=message.replace('(', r'\(')):
        spec(**changes)


@pytest.mark.parametrize(
    ('kind', 'name', 'parameters', 'message'),
    [
        ('robot', 'sine', {}, "controller kind 'robot': unknown"),
        ('mode', 'wave', {}, "mode 'wave': unknown"),
        ('mode', 'sine', {'hold_pressure': 1.0}, "unknown parameter 'hold_pressure'"),
        ('mode', 'sine', {'sine_period': 0}, 'sine_period = 0.0: must be > 0'),
        ('mode', 'hold', {'hold_pressure': [1, 2]}, 'hold_pressure'),
        ('mode', 'sine', {'max_pressure': -1}, 'max_pressure must be finite and > 0'),
        ('mode', 'sine', {'estimate_forces': 'yes'}, 'must be true or false'),
        ('controller', 'trial_controllers', {}, 'must be module:attribute'),
        ('controller', 'no_such_module:make', {}, 'cannot import no_such_module'),
        ('controller', 'trial_controllers:missing', {}, "no attribute 'missing'"),
        ('controller', 'trial_controllers:np', {}, 'is not callable'),
    ],
)
def test_bad_controllers_are_refused(kind, name, parameters, message):
    with pytest.raises(ValueError, match=message):
        ControllerSpec(kind, name, parameters)


def test_a_factory_that_does_not_make_a_controller_is_refused():
    controller = ControllerSpec('controller', 'trial_controllers:not_a_controller')
    with pytest.raises(ValueError, match='returned str, not a BatchController'):
        run_shard(spec(controller=controller), 0)
    with pytest.raises(ValueError, match=r"failed: TypeError: .*unexpected keyword argument 'x'"):
        run_shard(spec(controller=replace(controller, parameters={'x': 1})), 0)


@pytest.mark.parametrize('module', [spec_module, trial_module], ids=lambda module: module.__name__)
def test_the_docstring_examples_run(module):
    results = doctest.testmod(module, raise_on_error=False)
    assert results.attempted > 0, 'no docstring example ran'  # else nothing was tested
    assert results.failed == 0
