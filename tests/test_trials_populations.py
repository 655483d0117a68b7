"""Patient populations (docs/populations.md): reproducible, valid, as declared, refused when bad.

Independent references: scipy.stats (truncnorm, uniform) for each declared distribution, the
Gaussian copula's rank correlation (6/π)·asin(r/2) with the latent correlation the document
gives for the declared loadings, FingerJoint's own validation for every sampled finger, the
patient presets for the centres, and the tables of docs/populations.md.
"""

import math
import re
import traceback
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
import yaml
from exodigit_model.trials import (
    PATIENT_FIELDS,
    POPULATIONS,
    Correlation,
    Fixed,
    LogNormal,
    Normal,
    Population,
    Uniform,
    load_population,
    population_file,
)
from scipy import stats

from exodigit_model import (
    PATIENT_PRESETS,
    GloveModel,
    ParameterError,
    load_params,
    patient_file,
)

ROOT = Path(__file__).resolve().parents[1]
SAMPLES = 2000
SEED = 20250117
#: How many standard errors of a sample statistic a check allows (about 1 in 150,000 per check
#: for a correct sampler; the seeds are fixed, so a pass is repeatable).
STANDARD_ERRORS = 4.5
QUANTILES = (0.05, 0.25, 0.5, 0.75, 0.95)
ANGLES = ('rest_angle', 'rom_min', 'rom_max')
"""Fields in radians, tabulated in degrees in docs/populations.md."""


SHIPPED = {name: load_population(name) for name in POPULATIONS}
"""The shipped populations, by name."""


@pytest.fixture(scope='module')
def samples():
    """Every shipped population and SAMPLES patients drawn from it with SEED, by name."""
    return {
        name: (population, population.sample(SAMPLES, SEED))
        for name, population in SHIPPED.items()
    }


def random_parameters(population):
    """(field, joint index, distribution) of every parameter that is not fixed."""
    return [
        (key, j, joint[key])
        for j, joint in enumerate(population.joints)
        for key in PATIENT_FIELDS
        if not isinstance(joint[key], Fixed)
    ]


def test_shipped_populations_are_the_presets():
    assert POPULATIONS == PATIENT_PRESETS
    for name in POPULATIONS:
        assert population_file(name).is_file()
        assert load_population(name).name == name


def test_a_name_a_path_and_a_string_path_load_the_same_population():
    for name in POPULATIONS:
        path = population_file(name)
        assert load_population(name) == load_population(path) == load_population(str(path))


def test_same_seed_gives_the_same_patients_bit_for_bit(samples):
    for name, (population, patients) in samples.items():
        again = population.sample(SAMPLES, SEED)
        for key in PATIENT_FIELDS:
            assert again.arrays[key].tobytes() == patients.arrays[key].tobytes(), (name, key)
        assert population.sample(10, SEED).fingers == patients.fingers[:10]


def test_patient_i_does_not_depend_on_count(samples):
    for population, patients in samples.values():
        few = population.sample(7, SEED)
        assert len(few) == 7
        for key in PATIENT_FIELDS:
            assert few.arrays[key].tobytes() == patients.arrays[key][:7].tobytes()


def test_different_seeds_give_different_patients(samples):
    for population, patients in samples.values():
        other = population.sample(SAMPLES, SEED + 1)
        for key, j, _ in random_parameters(population):
            assert not np.any(other.arrays[key][:, j] == patients.arrays[key][:, j]), key


def test_every_patient_lies_within_the_bounds_and_is_a_valid_finger(samples):
    for name, (population, patients) in samples.items():
        for j, joint in enumerate(population.joints):
            for key, dist in joint.items():
                values = patients.arrays[key][:, j]
                assert values.shape == (SAMPLES,)
                assert np.all((dist.low <= values) & (values <= dist.high)), (name, key, j)
                if not isinstance(dist, Fixed):  # truncated, not clipped: nothing on a bound
                    assert np.all((dist.low < values) & (values < dist.high)), (name, key, j)
        arrays = patients.arrays
        assert np.all(arrays['rom_min'] < arrays['rom_max']), name
        assert np.all(arrays['rom_min'] <= arrays['rest_angle']), name
        assert np.all(arrays['rest_angle'] <= arrays['rom_max']), name
        assert len(patients.fingers) == SAMPLES  # each FingerJoint validates itself


def test_arrays_are_read_only(samples):
    _, patients = samples['stroke_moderate']
    with pytest.raises(ValueError, match='read-only'):
        patients.arrays['stiffness'][0, 0] = 1.0


def truncated_normal(mean, sd, low, high):
    return stats.truncnorm((low - mean) / sd, (high - mean) / sd, loc=mean, scale=sd)


def reference(dist):
    """(transform, scipy distribution of the transformed values) for a declared distribution."""
    if isinstance(dist, Uniform):
        return np.asarray, stats.uniform(loc=dist.low, scale=dist.high - dist.low)
    if isinstance(dist, Normal):
        return np.asarray, truncated_normal(dist.mean, dist.sd, dist.low, dist.high)
    logs = (math.log(x) for x in (dist.median, dist.gsd, dist.low, dist.high))
    return np.log, truncated_normal(*logs)


@pytest.mark.parametrize('name', POPULATIONS)
def test_sample_statistics_match_the_declared_distributions(samples, name):
    population, patients = samples[name]
    wrong = []
    for key, j, dist in random_parameters(population):
        transform, expected = reference(dist)
        values = transform(patients.arrays[key][:, j])
        mean_error = abs(values.mean() - expected.mean()) / (expected.std() / math.sqrt(SAMPLES))
        if mean_error > STANDARD_ERRORS:
            wrong.append(f'{key}[{j}] mean off by {mean_error:.1f} standard errors')
        for q in QUANTILES:
            below = np.mean(values <= expected.ppf(q))
            if abs(below - q) > STANDARD_ERRORS * math.sqrt(q * (1 - q) / SAMPLES):
                wrong.append(f'{key}[{j}]: {below:.3f} of the sample below the {q} quantile')
    assert not wrong


def latent_correlation(correlation, first, second):
    """The latent correlation docs/populations.md gives for two (field, joint) parameters."""
    (key_a, joint_a), (key_b, joint_b) = first, second
    loading_a = correlation.severity.get(key_a, 0.0)
    loading_b = correlation.severity.get(key_b, 0.0)
    if key_a == key_b and joint_a != joint_b:
        return loading_a**2 + (1 - loading_a**2) * correlation.joints
    return loading_a * loading_b


PAIRS = [
    (('stiffness', 0), ('rest_angle', 0)),  # rise together with severity
    (('stiffness', 0), ('stiffness', 1)),  # one parameter at two joints
    (('rest_angle', 2), ('rom_min', 0)),
    (('stiffness', 1), ('spasticity_threshold', 2)),  # falls as severity rises
    (('damping', 0), ('rom_max', 1)),
    (('rom_max', 0), ('rom_max', 2)),
]
"""(field, joint) pairs whose rank correlation is checked."""
CORRELATION_CASES = [
    (name, first, second)
    for name, population in SHIPPED.items()
    for first, second in PAIRS
    if not any(isinstance(population.joints[j][key], Fixed) for key, j in (first, second))
]
"""The pairs in which neither parameter is fixed, per shipped population."""
#: Allowed difference of Fisher's z of a rank correlation, whose standard error is about
#: sqrt(1.06 / (n - 3)).
RANK_TOLERANCE = STANDARD_ERRORS * math.sqrt(1.06 / (SAMPLES - 3))


def rank_correlation(patients, first, second):
    (key_a, joint_a), (key_b, joint_b) = first, second
    return stats.spearmanr(
        patients.arrays[key_a][:, joint_a], patients.arrays[key_b][:, joint_b]
    ).statistic


@pytest.mark.parametrize(('name', 'first', 'second'), CORRELATION_CASES)
def test_rank_correlations_are_as_declared(samples, name, first, second):
    population, patients = samples[name]
    r = latent_correlation(population.correlation, first, second)
    expected = 6 / math.pi * math.asin(r / 2)
    measured = rank_correlation(patients, first, second)
    assert abs(math.atanh(measured) - math.atanh(expected)) < RANK_TOLERANCE, (measured, expected)


def test_the_shipped_stroke_populations_declare_stiffness_and_rest_flexion_rising_together():
    for name in ('stroke_mild', 'stroke_moderate', 'stroke_severe'):
        correlation = SHIPPED[name].correlation
        assert latent_correlation(correlation, ('stiffness', 0), ('rest_angle', 0)) > 0.3
        assert latent_correlation(correlation, ('stiffness', 0), ('stiffness', 1)) > 0.8


def test_without_a_correlation_the_parameters_are_independent():
    population = replace(SHIPPED['stroke_moderate'], correlation=Correlation())
    patients = population.sample(SAMPLES, SEED)
    for first, second in PAIRS:
        measured = rank_correlation(patients, first, second)
        assert abs(math.atanh(measured)) < RANK_TOLERANCE, (first, second, measured)


@pytest.mark.parametrize('name', POPULATIONS)
def test_the_presets_lie_at_the_centre_of_their_populations(samples, name):
    population, patients = samples[name]
    preset = load_params(patient_file(name)).finger
    for j, joint in enumerate(population.joints):
        for key, dist in joint.items():
            value = getattr(preset.joints[j], key)
            if isinstance(dist, Fixed):
                assert dist.value == value, (key, j)
                continue
            below = np.mean(patients.arrays[key][:, j] < value)
            assert abs(below - 0.5) < STANDARD_ERRORS * math.sqrt(0.25 / SAMPLES), (key, j)


def test_a_sampled_finger_drives_the_glove_model(samples):
    _, patients = samples['stroke_severe']
    params = load_params()
    model = GloveModel(replace(params, finger=patients.fingers[0]))
    assert model.params.finger.joints[0].stiffness == patients.arrays['stiffness'][0, 0]
    assert model.solve([40e3] * 3).converged


def test_patients_keep_the_base_fingers_names_and_link_lengths():
    base = load_params().finger
    base = replace(
        base,
        joints=tuple(
            replace(joint, name=f'index_{joint.name}', link_half_length=2 * joint.link_half_length)
            for joint in base.joints
        ),
    )
    patients = load_population('stroke_mild').sample(3, SEED, base=base)
    for finger in patients.fingers:
        assert [joint.name for joint in finger.joints] == [joint.name for joint in base.joints]
        assert [joint.link_half_length for joint in finger.joints] == [
            joint.link_half_length for joint in base.joints
        ]


@pytest.mark.parametrize(
    ('count', 'seed', 'rule'),
    [
        (-1, 0, 'count = -1: must be >= 0'),
        (2.5, 0, 'count = 2.5: must be a whole number'),
        (2, -3, 'seed = -3: must be >= 0'),
        (2, '7', "seed = '7': must be a whole number"),
    ],
)
def test_bad_count_or_seed_is_refused(count, seed, rule):
    with pytest.raises(ValueError, match=re.escape(rule)):
        load_population('healthy').sample(count, seed)


def test_a_user_population_may_leave_fields_out_and_takes_its_name_from_the_file(tmp_path):
    path = tmp_path / 'my_patients.yaml'
    path.write_text(yaml.safe_dump(user_population()), 'utf-8')
    population = load_population(path)
    default = load_params().finger.joints
    assert population.name == 'my_patients'
    assert population.joints[0]['stiffness'] == LogNormal(0.2, 1.5, 0.08, 0.5)
    assert population.joints[2]['stiffness'] == Fixed(default[2].stiffness)
    assert population.joints[1]['rom_min'] == Fixed(default[1].rom_min)
    assert population.sample(5, 1).arrays['stiffness'].shape == (5, 3)


def user_population():
    """A valid user population: a few random parameters, the rest at the model defaults."""
    return {
        'description': 'test patients',
        'joints': [
            {
                'stiffness': {
                    'kind': 'lognormal',
                    'median': 0.2,
                    'gsd': 1.5,
                    'low': 0.08,
                    'high': 0.5,
                },
                'rest_angle': {'kind': 'normal', 'mean': 0.3, 'sd': 0.1, 'low': 0.1, 'high': 0.5},
            },
            {
                'stiffness': {
                    'kind': 'normal',
                    'mean': 0.15,
                    'sd': 0.03,
                    'low': 0.06,
                    'high': 0.3,
                },
                'damping': 0.004,
            },
            {'spasticity_threshold': {'kind': 'uniform', 'low': 0.2, 'high': 0.8}},
        ],
        'correlation': {'joints': 0.5, 'severity': {'stiffness': 0.6}},
    }


DELETE = object()
"""Marks a key to remove from the user population."""

BAD_EDITS = [
    (('joints', 1, 'stiffness', 'sd'), -0.03, 'joints[1].stiffness.sd = -0.03', 'must be > 0'),
    (('joints', 1, 'stiffness', 'sd'), DELETE, 'joints[1].stiffness.sd', 'missing'),
    (('joints', 1, 'stiffness', 'std'), 0.03, 'joints[1].stiffness.std', 'unknown key'),
    (('joints', 1, 'stiffness', 'kind'), 'gaussian', 'joints[1].stiffness.kind', 'must be one of'),
    (
        ('joints', 1, 'stiffness', 'mean'),
        0.4,
        'joints[1].stiffness.mean = 0.4',
        'must lie within [low, high]',
    ),
    (
        ('joints', 1, 'stiffness', 'low'),
        0.35,
        'joints[1].stiffness.low = 0.35',
        'must be below high',
    ),
    (('joints', 1, 'stiffness', 'low'), -0.01, 'joints[1].stiffness.low', 'must be >= 0'),
    (('joints', 1, 'stiffness', 'high'), '.3', 'joints[1].stiffness.high', 'must be a number'),
    (('joints', 0, 'stiffness', 'gsd'), 1.0, 'joints[0].stiffness.gsd = 1.0', 'must be > 1'),
    (('joints', 0, 'stiffness', 'low'), 0.0, 'joints[0].stiffness.low = 0.0', 'must be > 0'),
    (('joints', 0, 'stifness'), 0.1, 'joints[0].stifness', 'unknown key'),
    (
        ('joints', 0, 'rest_angle', 'low'),
        -0.4,
        'joints[0].rest_angle.low',
        'must lie within the range of motion',
    ),
    (
        ('joints', 0, 'rest_angle', 'high'),
        1.6,
        'joints[0].rest_angle.high',
        'must lie within the range of motion',
    ),
    (
        ('joints', 2, 'rom_min'),
        {'kind': 'uniform', 'low': 0.0, 'high': 1.5},
        'joints[2].rom_min.high',
        'must be below rom_max',
    ),
    (('joints', 1, 'damping'), -0.004, 'joints[1].damping', 'must be >= 0'),
    (('joints', 1, 'damping'), 'stiff', "joints[1].damping = 'stiff'", 'must be a number'),
    (('joints', 1, 'damping'), float('nan'), 'joints[1].damping = nan', 'must be finite'),
    (
        ('joints', 2, 'spasticity_threshold', 'low'),
        0.0,
        'joints[2].spasticity_threshold.low',
        'must be > 0',
    ),
    (('joints', 2), DELETE, 'joints = 2', 'must be a list of exactly 3'),
    (('joints',), {'mcp': {}}, 'joints = ', 'must be a list of exactly 3'),
    (('correlation', 'joints'), 1.5, 'correlation.joints = 1.5', 'must be within [0, 1]'),
    (
        ('correlation', 'severity', 'stiffness'),
        -2,
        'correlation.severity.stiffness = -2',
        'must be within [-1, 1]',
    ),
    (('correlation', 'severity', 'stifness'), 0.5, 'correlation.severity.stifness', 'unknown key'),
    (('correlation', 'join'), 0.5, 'correlation.join', 'unknown key'),
    (('name',), '', "name = ''", 'must be a non-empty string'),
    (('description',), 3, 'description = 3', 'must be a string'),
    (('patients',), 10, 'patients', 'unknown key'),
]


def edited(path, value):
    data = user_population()
    *parents, last = path
    target = data
    for key in parents:
        target = target[key]
    if value is DELETE:
        del target[last]
    else:
        target[last] = value
    return yaml.safe_dump(data)


def assert_refused(path, key, rule):
    with pytest.raises(ParameterError) as caught:
        load_population(path)
    message = str(caught.value)
    assert message.startswith(f'{path}: '), message
    assert key in message, message
    assert rule in message, message
    assert 'During handling' not in ''.join(traceback.format_exception(caught.value))


@pytest.mark.parametrize(
    ('where', 'value', 'key', 'rule'),
    BAD_EDITS,
    ids=[f'{"/".join(map(str, case[0]))}-{case[3]}' for case in BAD_EDITS],
)
def test_a_bad_population_file_is_refused_with_the_key_and_the_rule(
    tmp_path, where, value, key, rule
):
    path = tmp_path / 'bad.yaml'
    path.write_text(edited(where, value), 'utf-8')
    assert_refused(path, key, rule)


@pytest.mark.parametrize(
    ('text', 'key', 'rule'),
    [
        ('joints: [\n', 'bad.yaml', 'not valid YAML'),
        ('- 1\n- 2\n', 'file = [1, 2]', 'must be a mapping'),
        ('', 'file = None', 'must be a mapping'),
    ],
)
def test_a_file_that_is_not_a_population_is_refused(tmp_path, text, key, rule):
    path = tmp_path / 'bad.yaml'
    path.write_text(text, 'utf-8')
    assert_refused(path, key, rule)


def key_paths(data, path=()):
    """Every key path of nested dicts and lists, e.g. ('joints', 0, 'stiffness', 'sd')."""
    items = data.items() if isinstance(data, dict) else enumerate(data)
    for key, value in items:
        yield (*path, key)
        if isinstance(value, dict | list):
            yield from key_paths(value, (*path, key))


@pytest.mark.parametrize(
    'value',
    [None, 'x', True, [1.0], {'kind': [1]}, {1: 2, 'a': 3}, float('inf'), 1e-300, -1e300],
    ids=repr,
)
def test_any_value_anywhere_loads_or_is_refused_with_a_parameter_error(tmp_path, value):
    path = tmp_path / 'odd.yaml'
    for where in key_paths(user_population()):
        path.write_text(edited(where, value), 'utf-8')
        try:
            assert len(load_population(path).sample(20, SEED).fingers) == 20
        except ParameterError as error:
            assert str(error).startswith(f'{path}: '), error


def test_a_missing_file_or_unknown_name_is_refused_with_the_shipped_names(tmp_path):
    for source in (tmp_path / 'none.yaml', 'stroke_moderat'):
        with pytest.raises(ParameterError, match=r'cannot read population file.*stroke_moderate'):
            load_population(source)
    with pytest.raises(ParameterError, match="population 'stroke': unknown"):
        population_file('stroke')


def test_a_population_built_in_python_is_checked_as_a_file_is():
    joint = {key: Fixed(value) for key, value in vars_of(load_params().finger.joints[0]).items()}
    Population('fixed', (joint, joint, joint))
    bad = dict(joint, rest_angle=Uniform(-1.0, 0.5))
    with pytest.raises(ParameterError, match=r'joints\[1\]\.rest_angle\.low: .*range of motion'):
        Population('bad', (joint, bad, joint))
    with pytest.raises(ParameterError, match=r'joints\[2\] has fields'):
        Population('short', (joint, joint, {'stiffness': Fixed(0.1)}))


def vars_of(joint):
    return {key: getattr(joint, key) for key in PATIENT_FIELDS}


DOCUMENT = ROOT / 'docs' / 'populations.md'


def documented(dist, key):
    """A distribution as docs/populations.md tabulates it (angles in degrees)."""
    scale = 180 / math.pi if key in ANGLES else 1.0

    def number(x):
        return f'{round(x * scale, 1):g}' if key in ANGLES else f'{x:g}'

    if isinstance(dist, Fixed):
        return number(dist.value)
    bounds = f'[{number(dist.low)}, {number(dist.high)}]'
    if isinstance(dist, Uniform):
        return f'U{bounds}'
    if isinstance(dist, Normal):
        return f'N({number(dist.mean)}, {number(dist.sd)}) {bounds}'
    return f'LN({number(dist.median)}, ×{dist.gsd:g}) {bounds}'


@pytest.mark.parametrize('name', POPULATIONS)
def test_the_documents_table_is_the_population_file(name):
    text = DOCUMENT.read_text('utf-8')
    section = text.split(f'\n### {name}\n', 1)[1].split('\n#', 1)[0]
    population = load_population(name)
    for key in PATIENT_FIELDS:
        cells = [documented(joint[key], key) for joint in population.joints]
        row = f'| {key} | ' + ' | '.join(cells) + ' |'
        assert row in section, row
