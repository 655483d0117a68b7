"""Per-patient trial metrics, their aggregates and the pass/fail rule (docs/trials.md).

Independent answers: every metric of a small synthetic record (2 patients, 4 steps) worked out
by hand in the comments below; np.percentile and sorting for the aggregates; counts of patients
for the rules. The record fed step by step, in chunks and in one piece must give the same
metrics.
"""

import doctest
import json
import re
from pathlib import Path

import numpy as np
import pytest
from exodigit_model.control import SafetyLimits
from exodigit_model.trials import (
    DEFAULT_FORCE_LIMIT,
    FUNCTIONAL_RANGE,
    METRIC_NAMES,
    METRICS,
    MetricAccumulator,
    MetricSettings,
    PatientMetrics,
    Rule,
    aggregates,
    column_names,
    metrics,
    rules,
    summarize,
)

ROOT = Path(__file__).resolve().parents[1]
#: Sums taken in another order (chunks against single steps) may differ in the last bits.
SUM_ORDER = 1e-14
#: Hand-worked values are exact decimals; float arithmetic reaches them to a few ulps.
HAND = 1e-12

# The record: T = 4 steps at 10 Hz (Δt = 0.1 s) of N = 2 patients, joints MCP, PIP, DIP.
RATE = 10.0
LIMIT = 5.0
# A functional range that is easy to intersect by hand: MCP [0.1, 0.5], PIP [0, 0.4],
# DIP [0.5, 1.5] rad.
FUNCTIONAL = ((0.1, 0.0, 0.5), (0.5, 0.4, 1.5))
SETTINGS = MetricSettings(rate_hz=RATE, force_limit=LIMIT, functional_rom=FUNCTIONAL)
Q = np.array(
    [  # step: [patient 0 (MCP, PIP, DIP), patient 1]
        [[0.0, 0.1, 0.0], [0.3, 0.0, 1.2]],
        [[0.2, 0.1, 0.5], [0.3, -0.1, 1.2]],
        [[0.4, 0.1, 1.0], [0.6, 0.0, 1.2]],
        [[0.2, 0.1, 0.5], [0.9, 0.1, 1.2]],
    ]
)
TARGET = np.array(  # one target for both patients; the PIP target never moves
    [[0.0, 0.1, 0.0], [0.2, 0.1, 0.5], [0.4, 0.1, 1.0], [0.6, 0.1, 1.0]]
)
FORCES = np.array(
    [
        [[1.0, 0.0, 5.0], [7.0, -8.0, 0.0]],
        [[-6.0, 0.0, 5.0], [7.0, 0.0, 0.0]],
        [[5.0, 0.0, 5.0], [0.0, 0.0, 6.0]],
        [[2.0, 0.0, 5.0], [0.0, 0.0, 0.0]],
    ]
)
PRESSURE = np.array(
    [
        [[0.0, 5e3, 0.0], [3e4, 1e3, 0.0]],
        [[1e4, 5e3, 0.0], [2e4, 2e3, 0.0]],
        [[2e4, 5e3, 0.0], [1e4, 3e3, 0.0]],
        [[1e4, 5e3, 0.0], [0.0, 4e3, 0.0]],
    ]
)
LIMITED = np.array([[False, False], [True, False], [True, False], [False, False]])
WARNING = np.array([[False, True], [False, False], [False, False], [False, True]])
OUTSIDE = np.array([[True, False], [True, False], [False, False], [True, True]])

EXPECTED = {
    # max − min of q: p0 MCP 0.4 − 0, PIP 0, DIP 1 − 0; p1 MCP 0.9 − 0.3, PIP 0.1 − (−0.1), DIP 0
    'rom_rad': [[0.4, 0.0, 1.0], [0.6, 0.2, 0.0]],
    # max − min of the target: MCP 0.6, PIP 0, DIP 1.0, the same for both patients
    'target_rom_rad': [[0.6, 0.0, 1.0], [0.6, 0.0, 1.0]],
    # rom / target rom; PIP: the target does not move, so 1 (whatever the finger did)
    'rom_fraction': [[0.4 / 0.6, 1.0, 1.0], [1.0, 1.0, 0.0]],
    # overlap of [min q, max q] with the functional range, over its width:
    # p0 MCP [0, 0.4]∩[0.1, 0.5] = 0.3 of 0.4; PIP [0.1, 0.1] has no width: 0;
    #    DIP [0, 1]∩[0.5, 1.5] = 0.5 of 1.0
    # p1 MCP [0.3, 0.9]∩[0.1, 0.5] = 0.2 of 0.4; PIP [−0.1, 0.1]∩[0, 0.4] = 0.1 of 0.4; DIP 0
    'functional_rom_fraction': [[0.75, 0.0, 0.5], [0.5, 0.25, 0.0]],
    # q − q*: p0 MCP 0, 0, 0, −0.4: √(0.16/4) = 0.2; PIP 0; DIP 0, 0, 0, −0.5: √(0.25/4) = 0.25
    #         p1 MCP 0.3, 0.1, 0.2, 0.3: √(0.23/4); PIP −0.1, −0.2, −0.1, 0: √(0.06/4);
    #            DIP 1.2, 0.7, 0.2, 0.2: √(2.01/4)
    'tracking_rmse_rad': [
        [0.2, 0.0, 0.25],
        [np.sqrt(0.23 / 4), np.sqrt(0.06 / 4), np.sqrt(2.01 / 4)],
    ],
    # over steps and joints: p0 √((0.16 + 0 + 0.25)/12), p1 √((0.23 + 0.06 + 2.01)/12)
    'overall_tracking_rmse_rad': [np.sqrt(0.41 / 12), np.sqrt(2.30 / 12)],
    # largest |f|: p0 MCP |−6|, PIP 0, DIP 5; p1 MCP 7, PIP |−8|, DIP 6
    'peak_force_n': [[6.0, 0.0, 5.0], [7.0, 8.0, 6.0]],
    # mean |f|: p0 (1 + 6 + 5 + 2)/4, 0, 5; p1 (7 + 7)/4, 8/4, 6/4
    'mean_force_n': [[3.5, 0.0, 5.0], [3.5, 2.0, 1.5]],
    # steps with a contact above 5 N (5 N itself is not above): p0 step 2 only (6 N), so
    # 1 × 0.1 s; p1 steps 1 (7, 8 N), 2 (7 N), 3 (6 N): 3 × 0.1 s
    'time_over_force_s': [0.1, 0.3],
    # highest chamber pressure
    'peak_pressure_pa': [[2e4, 5e3, 0.0], [3e4, 4e3, 0.0]],
    # steps the limiter acted: p0 2, p1 0; steps without convergence: p0 0, p1 2
    'limiter_steps': [2.0, 0.0],
    'solver_warning_steps': [0.0, 2.0],
    # steps outside the validated model: p0 steps 1, 2, 4; p1 step 4
    'outside_model_steps': [3.0, 1.0],
}


def record_steps(steps):
    """The keyword arguments of update() for the record's steps ``steps`` (a slice or index)."""
    return {
        'q': Q[steps],
        'target': TARGET[steps],
        'forces': FORCES[steps],
        'pressure': PRESSURE[steps],
        'limited': LIMITED[steps],
        'solver_warning': WARNING[steps],
        'outside_model': OUTSIDE[steps],
    }


def accumulate(chunks, settings=SETTINGS):
    """The record fed in chunks of the given lengths (1 = one step, without a time axis)."""
    accumulator = MetricAccumulator(2, settings)
    start = 0
    for length in chunks:
        steps = start if length == 1 else slice(start, start + length)
        accumulator.update(**record_steps(steps))
        start += length
    assert start == len(Q)
    return accumulator.result()


def test_every_metric_of_the_record_is_the_hand_worked_value():
    result = accumulate([4])
    assert set(EXPECTED) == set(METRIC_NAMES)
    for name, expected in EXPECTED.items():
        np.testing.assert_allclose(
            result.values[name], expected, rtol=HAND, atol=HAND, err_msg=name
        )
    assert result.steps == 4
    assert result.duration == pytest.approx(0.4)
    assert len(result) == 2


@pytest.mark.parametrize('chunks', [[1, 1, 1, 1], [1, 3], [2, 2], [3, 1]])
def test_streaming_in_steps_or_chunks_equals_one_pass(chunks):
    whole = accumulate([4])
    parts = accumulate(chunks)
    for name in METRIC_NAMES:
        np.testing.assert_allclose(
            parts.values[name], whole.values[name], rtol=SUM_ORDER, atol=0, err_msg=name
        )


def test_results_are_finite_read_only_and_shaped_per_joint_or_per_patient():
    result = accumulate([4])
    for metric in METRICS:
        values = result.values[metric.name]
        assert values.shape == ((2, 3) if metric.per_joint else (2,)), metric.name
        assert np.all(np.isfinite(values)), metric.name
        with pytest.raises(ValueError, match='read-only'):
            values[0] = 1.0


def test_a_force_exactly_at_the_limit_is_not_over_it_and_one_just_above_is():
    at = MetricAccumulator(1, MetricSettings(rate_hz=RATE, force_limit=LIMIT))
    above = MetricAccumulator(1, MetricSettings(rate_hz=RATE, force_limit=LIMIT))
    step = {'q': np.zeros((1, 3)), 'target': np.zeros(3), 'pressure': np.zeros((1, 3))}
    flags = {'limited': False, 'solver_warning': False, 'outside_model': False}
    at.update(forces=np.array([[0.0, -LIMIT, LIMIT]]), **step, **flags)
    above.update(forces=np.array([[0.0, np.nextafter(-LIMIT, -np.inf), 0.0]]), **step, **flags)
    assert at.result().values['time_over_force_s'][0] == 0.0
    assert above.result().values['time_over_force_s'][0] == pytest.approx(1.0 / RATE)


def test_the_time_over_the_limit_counts_steps_times_the_step_period():
    # the same steps at twice the rate last half as long
    fast = accumulate([4], MetricSettings(rate_hz=2 * RATE, force_limit=LIMIT))
    np.testing.assert_allclose(fast.values['time_over_force_s'], [0.05, 0.15], rtol=HAND)
    # a higher limit: p0 is never above 7 N, p1 only at step 1 (8 N)
    high = accumulate([4], MetricSettings(rate_hz=RATE, force_limit=7.0))
    np.testing.assert_allclose(high.values['time_over_force_s'], [0.0, 0.1], rtol=HAND)


def test_each_patient_may_have_a_target_of_its_own():
    # patient 1's own target: the record's target shifted by +0.1 rad at every joint; patient 0
    # keeps the record's. Ranges are unchanged; patient 1's errors shift by −0.1:
    # MCP 0.2, 0, 0.1, 0.2: √(0.09/4); PIP −0.2, −0.3, −0.2, −0.1: √(0.18/4);
    # DIP 1.1, 0.6, 0.1, 0.1: √(1.59/4)
    own = np.stack([TARGET, TARGET + 0.1], axis=1)
    accumulator = MetricAccumulator(2, SETTINGS)
    for k in range(4):
        accumulator.update(**(record_steps(k) | {'target': own[k]}))
    result = accumulator.result()
    np.testing.assert_allclose(result.values['target_rom_rad'], EXPECTED['target_rom_rad'])
    np.testing.assert_allclose(
        result.values['tracking_rmse_rad'],
        [[0.2, 0.0, 0.25], np.sqrt(np.array([0.09, 0.18, 1.59]) / 4)],
        rtol=HAND,
    )
    chunked = MetricAccumulator(2, SETTINGS)
    chunked.update(**(record_steps(slice(0, 4)) | {'target': own}))
    for name in METRIC_NAMES:
        np.testing.assert_allclose(
            chunked.result().values[name], result.values[name], rtol=SUM_ORDER, err_msg=name
        )


def test_shared_and_own_targets_can_be_mixed_over_the_steps():
    # steps 1-2 shared, steps 3-4 each patient's own (equal to the shared ones): same result
    accumulator = MetricAccumulator(2, SETTINGS)
    accumulator.update(**record_steps(slice(0, 2)))
    own = np.repeat(TARGET[2:, np.newaxis], 2, axis=1)
    accumulator.update(**(record_steps(slice(2, 4)) | {'target': own}))
    for name in METRIC_NAMES:
        np.testing.assert_allclose(
            accumulator.result().values[name], accumulate([4]).values[name], rtol=SUM_ORDER
        )


def test_the_result_can_be_taken_mid_session_and_the_session_goes_on():
    accumulator = MetricAccumulator(2, SETTINGS)
    accumulator.update(**record_steps(slice(0, 2)))
    first = accumulator.result()
    assert first.steps == 2
    np.testing.assert_allclose(first.values['rom_rad'], [[0.2, 0.0, 0.5], [0.0, 0.1, 0.0]])
    accumulator.update(**record_steps(slice(2, 4)))
    np.testing.assert_allclose(accumulator.result().values['rom_rad'], EXPECTED['rom_rad'])


def test_the_default_settings_are_the_cited_ones():
    settings = MetricSettings()
    assert settings.rate_hz == 100.0
    # docs/trials.md: the pressure_command limiter's force, within the sourced bounds
    assert settings.force_limit == DEFAULT_FORCE_LIMIT == SafetyLimits().max_contact_force
    # Bain et al. 2015: 19-71°, 23-87°, 10-64°
    np.testing.assert_allclose(
        np.degrees(settings.functional_rom), [[19.0, 23.0, 10.0], [71.0, 87.0, 64.0]]
    )
    assert settings.functional_rom == FUNCTIONAL_RANGE


def test_a_finger_covering_the_functional_range_scores_one_and_a_still_one_zero():
    low, high = np.array(FUNCTIONAL_RANGE)
    accumulator = MetricAccumulator(2)
    for q in (low - 0.1, high + 0.1):
        accumulator.update(
            q=np.stack([q, np.full(3, 0.5)]),
            target=q,
            forces=np.zeros((2, 3)),
            pressure=np.zeros((2, 3)),
            limited=False,
            solver_warning=False,
            outside_model=False,
        )
    fraction = accumulator.result().values['functional_rom_fraction']
    np.testing.assert_array_equal(fraction, [[1.0, 1.0, 1.0], [0.0, 0.0, 0.0]])


# -- the table -----------------------------------------------------------------------------

SUFFIX = {'rad': '_rad', 'N': '_n', 's': '_s', 'Pa': '_pa', 'steps': '_steps', '1': '_fraction'}


@pytest.mark.parametrize('metric', METRICS, ids=lambda metric: metric.name)
def test_each_metric_name_ends_with_its_unit(metric):
    assert metric.name.endswith(SUFFIX[metric.unit])
    assert metric.worse in ('high', 'low', None)
    assert metric.description


def test_the_columns_are_each_joint_of_a_per_joint_metric_and_the_others_once():
    names = column_names()
    assert names[:3] == ('rom_rad.mcp', 'rom_rad.pip', 'rom_rad.dip')
    assert 'time_over_force_s' in names and 'time_over_force_s.mcp' not in names
    assert len(names) == sum(3 if metric.per_joint else 1 for metric in METRICS)
    result = accumulate([4])
    columns = result.columns()
    assert tuple(columns) == names
    np.testing.assert_array_equal(columns['peak_force_n.pip'], [0.0, 8.0])


def test_a_per_joint_metric_without_a_joint_is_each_patients_worst_joint():
    result = accumulate([4])
    np.testing.assert_array_equal(result.column('peak_force_n'), [6.0, 8.0])  # highest
    np.testing.assert_allclose(result.column('rom_fraction'), [0.4 / 0.6, 0.0])  # lowest
    for name in ('target_rom_rad', 'peak_force', 'peak_force_n.thumb', 'limiter_steps.mcp'):
        with pytest.raises(KeyError, match=re.escape(repr(name))):
            result.column(name)


def test_the_docs_table_lists_every_metric_with_its_unit_and_kind():
    text = (ROOT / 'docs' / 'trials.md').read_text().split('\n## Metrics\n')[1].split('\n## ')[0]
    rows = {
        match['name']: match
        for match in re.finditer(
            r'^\| `(?P<name>\w+)` \| (?P<unit>[^|]+) \| (?P<joint>[^|]+) \|', text, re.MULTILINE
        )
    }
    assert set(rows) == set(METRIC_NAMES)
    for metric in METRICS:
        row = rows[metric.name]
        assert row['unit'].strip() == metric.unit, metric.name
        assert row['joint'].strip() == ('per joint' if metric.per_joint else 'per patient')


def test_patients_of_shards_concatenate_to_the_whole_trial():
    whole = accumulate([4])
    shards = []
    for patient in (0, 1):
        accumulator = MetricAccumulator(1, SETTINGS)
        step = record_steps(slice(0, 4))
        accumulator.update(
            **{
                key: value[:, patient : patient + 1] if key != 'target' else value
                for key, value in step.items()
            }
        )
        shards.append(accumulator.result())
    joined = PatientMetrics.concatenate(shards)
    for name in METRIC_NAMES:
        np.testing.assert_allclose(joined.values[name], whole.values[name], rtol=SUM_ORDER)
    with pytest.raises(ValueError, match='same steps and settings'):
        PatientMetrics.concatenate([whole, accumulate([4], MetricSettings(rate_hz=RATE))])
    with pytest.raises(ValueError, match='no parts'):
        PatientMetrics.concatenate([])


# -- refusals -------------------------------------------------------------------------------


@pytest.mark.parametrize(
    ('change', 'message'),
    [
        ({'q': np.zeros((3, 3))}, r'q must have shape \(2, 3\)'),
        ({'q': np.zeros((2, 2))}, 'q must have shape'),
        ({'q': 'angles'}, 'q = .*must be an array of numbers'),
        ({'forces': np.zeros((2, 2, 3))}, r'forces must have shape \(2, 3\)'),
        ({'target': np.zeros(2)}, r'target must have shape'),
        ({'target': np.zeros((3, 3))}, r'target must have shape'),
        ({'limited': np.zeros(2)}, 'limited must be bool'),
        ({'limited': np.zeros(3, bool)}, r'limited must have shape \(2,\)'),
        ({'solver_warning': np.zeros((2, 2), bool)}, 'solver_warning must have shape'),
        ({'outside_model': np.zeros(2, int)}, 'outside_model must be bool'),
        (
            {'q': np.array([[0.0, 0.0, 0.0], [0.0, np.nan, 0.0]])},
            'q is not finite: nan at step 0 of the update, patient 1, pip',
        ),
        ({'pressure': np.full((2, 3), np.inf)}, 'pressure is not finite: inf .*patient 0, mcp'),
        ({'target': np.array([0.0, 0.0, -np.inf])}, 'target is not finite: -inf .*, dip'),
    ],
)
def test_a_bad_step_is_refused_by_name_and_adds_nothing(change, message):
    accumulator = MetricAccumulator(2, SETTINGS)
    accumulator.update(**record_steps(0))
    with pytest.raises(ValueError, match=message):
        accumulator.update(**(record_steps(1) | change))
    assert accumulator.steps == 1
    np.testing.assert_array_equal(accumulator.result().values['rom_rad'], np.zeros((2, 3)))


def test_a_chunk_needs_a_target_per_step_and_flags_per_step():
    accumulator = MetricAccumulator(2, SETTINGS)
    with pytest.raises(ValueError, match=r'target must have shape \(4, 3\) or \(4, 2, 3\)'):
        accumulator.update(**(record_steps(slice(0, 4)) | {'target': TARGET[0]}))
    with pytest.raises(ValueError, match=r'limited must have shape .*\(4, 2\)'):
        accumulator.update(**(record_steps(slice(0, 4)) | {'limited': LIMITED[0]}))
    with pytest.raises(ValueError, match=r'forces must have shape .*\(4, 2, 3\)'):
        accumulator.update(**(record_steps(slice(0, 4)) | {'forces': FORCES[:3]}))
    accumulator.update(**(record_steps(slice(0, 4)) | {'limited': True}))  # one bool for all
    np.testing.assert_array_equal(accumulator.result().values['limiter_steps'], [4.0, 4.0])


def test_no_result_without_steps_and_no_accumulator_without_patients():
    with pytest.raises(ValueError, match='no steps'):
        MetricAccumulator(2).result()
    for count in (0, -1, 2.0, True):
        with pytest.raises(ValueError, match='count'):
            MetricAccumulator(count)


@pytest.mark.parametrize(
    ('settings', 'message'),
    [
        ({'rate_hz': 0.0}, 'rate_hz = 0.0: must be > 0'),
        ({'force_limit': -1.0}, 'force_limit = -1.0: must be > 0'),
        ({'force_limit': float('nan')}, 'force_limit = nan: must be finite'),
        ({'functional_rom': ((0.0, 0.0), (1.0, 1.0))}, 'functional_rom = .*three finite'),
        ({'functional_rom': ((0.0, 0.5, 0.0), (1.0, 0.5, 1.0))}, 'at the pip: lower end'),
    ],
)
def test_bad_settings_are_refused_by_name(settings, message):
    with pytest.raises(ValueError, match=message):
        MetricSettings(**settings)


# -- aggregates -----------------------------------------------------------------------------


def metrics_with_peak_forces(values):
    """Metrics of one step whose MCP contact force of patient i is ``values[i]`` (N)."""
    forces = np.zeros((len(values), 3))
    forces[:, 0] = values
    accumulator = MetricAccumulator(len(values))
    accumulator.update(
        q=np.zeros((len(values), 3)),
        target=np.zeros(3),
        forces=forces,
        pressure=np.zeros((len(values), 3)),
        limited=False,
        solver_warning=False,
        outside_model=False,
    )
    return accumulator.result()


def test_percentiles_and_worst_patients_of_a_column():
    values = [3.0, 1.0, 4.0, 1.0, 5.0]
    summary = summarize(
        metrics_with_peak_forces(values), percentiles=(0, 25, 50, 100, 99.9), worst=3
    )
    entry = summary['metrics']['peak_force_n.mcp']
    # sorted 1, 1, 3, 4, 5: the 25th percentile is the 2nd value (index 1.0), the 99.9th lies
    # 0.996 of the way from 4 to 5 (index 3.996)
    assert entry['percentiles'] == {
        'p0': 1.0,
        'p25': 1.0,
        'p50': 3.0,
        'p100': 5.0,
        'p99.9': pytest.approx(4.996),
    }
    assert entry['mean'] == pytest.approx(14.0 / 5)
    assert entry['unit'] == 'N'
    assert entry['worst'] == [
        {'patient': 4, 'value': 5.0},
        {'patient': 2, 'value': 4.0},
        {'patient': 0, 'value': 3.0},
    ]
    # the worst joint of each patient is its MCP (the others are 0)
    assert summary['metrics']['peak_force_n']['worst'][0] == {'patient': 4, 'value': 5.0}
    assert (summary['patients'], summary['steps']) == (5, 1)
    assert summary['force_limit_n'] == DEFAULT_FORCE_LIMIT


def test_the_worst_are_the_lowest_where_low_is_worse_and_ties_keep_the_patients_order():
    summary = summarize(accumulate([4]), worst=5)
    assert summary['metrics']['rom_fraction.dip']['worst'] == [
        {'patient': 1, 'value': 0.0},
        {'patient': 0, 'value': 1.0},
    ]
    assert summary['metrics']['rom_fraction.pip']['worst'] == [
        {'patient': 0, 'value': 1.0},
        {'patient': 1, 'value': 1.0},
    ]
    assert 'worst' not in summary['metrics']['target_rom_rad.mcp']
    assert 'target_rom_rad' not in summary['metrics']


def test_the_summary_covers_every_column_and_is_plain_json():
    summary = summarize(accumulate([4]))
    assert set(column_names()) <= set(summary['metrics'])
    text = json.dumps(summary, allow_nan=False)
    assert json.loads(text) == summary
    assert list(summary['metrics']['time_over_force_s']['percentiles']) == [
        'p1',
        'p5',
        'p50',
        'p95',
        'p99',
    ]


@pytest.mark.parametrize(
    ('options', 'message'),
    [
        ({'percentiles': (50, 101)}, 'percentiles'),
        ({'percentiles': (-1,)}, 'percentiles'),
        ({'worst': -1}, 'worst = -1'),
        ({'worst': 1.5}, 'worst = 1.5'),
    ],
)
def test_bad_summary_options_are_refused(options, message):
    with pytest.raises(ValueError, match=message):
        summarize(accumulate([4]), **options)


# -- rules ----------------------------------------------------------------------------------


@pytest.mark.parametrize(
    ('text', 'fields'),
    [
        ('peak_force_n <= 5 for 99%', ('peak_force_n', '<=', 5.0, 99.0, None)),
        ('rom_fraction >= 0.8 for 95%', ('rom_fraction', '>=', 0.8, 95.0, None)),
        ('peak_force_n.pip <= 4 for 100%', ('peak_force_n', '<=', 4.0, 100.0, 'pip')),
        ('  time_over_force_s<0.5  for  99.5 %  ', ('time_over_force_s', '<', 0.5, 99.5, None)),
        ('tracking_rmse_rad.dip > -1e-3 for 0.1%', ('tracking_rmse_rad', '>', -1e-3, 0.1, 'dip')),
    ],
)
def test_good_rules_are_parsed(text, fields):
    rule = Rule.parse(text)
    assert (rule.metric, rule.comparison, rule.threshold, rule.percent, rule.joint) == fields
    assert Rule.parse(str(rule)) == rule


@pytest.mark.parametrize(
    ('text', 'message'),
    [
        ('peak_force <= 5 for 99%', "unknown metric 'peak_force' \\(known: rom_rad, .*\\)"),
        ('peak_force_n <= 5', "no 'for SHARE%'"),
        ('peak_force_n <= 5 for 99', "share '99': must be a percentage"),
        ('peak_force_n == 5 for 99%', "comparison '==': must be one of <=, <, >=, >"),
        ('peak_force_n 5 for 99%', 'must be METRIC\\[.JOINT\\] OP THRESHOLD'),
        ('peak_force_n <= five for 99%', "threshold 'five': not a number"),
        ('peak_force_n <= nan for 99%', 'threshold = nan: must be finite'),
        ('peak_force_n <= 5 for 0%', 'share 0%: must be above 0 %'),
        ('peak_force_n <= 5 for 101%', 'share 101%: must be above 0 % and at most 100 %'),
        ('peak_force_n.thumb <= 5 for 99%', "unknown joint 'thumb' \\(known: mcp, pip, dip\\)"),
        ('limiter_steps.mcp <= 5 for 99%', 'one value per patient, not one per joint'),
        ('', "no 'for SHARE%'"),
    ],
)
def test_bad_rules_are_refused_naming_the_problem(text, message):
    with pytest.raises(ValueError, match=message) as refused:
        Rule.parse(text)
    assert str(refused.value).startswith(f'rule {text!r}: ')
    assert 'form: METRIC[.JOINT] OP THRESHOLD for SHARE%' in str(refused.value)


def test_a_rule_built_in_python_is_checked_the_same_way():
    with pytest.raises(ValueError, match='unknown metric'):
        Rule('peak_force', '<=', 5.0, 99.0)
    with pytest.raises(ValueError, match='threshold = True: must be a number'):
        Rule('peak_force_n', '<=', True, 99.0)


HUNDRED = [0.0] * 100
HUNDRED[12] = 5.0  # exactly at the threshold: meets <= 5, not < 5
HUNDRED[37] = 8.0  # above it


@pytest.mark.parametrize(
    ('text', 'held', 'passed'),
    [
        ('peak_force_n <= 5 for 99%', 99, True),  # 99 of 100: exactly the share
        ('peak_force_n <= 5 for 99.5%', 99, False),
        ('peak_force_n < 5 for 99%', 98, False),
        ('peak_force_n < 5 for 98%', 98, True),
        ('peak_force_n.mcp <= 4.9 for 98%', 98, True),
        ('peak_force_n.pip <= 0 for 100%', 100, True),
        ('peak_force_n.mcp >= 5 for 2%', 2, True),
        ('peak_force_n.mcp > 5 for 2%', 1, False),
        ('peak_force_n >= 5 for 1%', 0, False),  # every joint: PIP and DIP are 0
    ],
)
def test_rules_pass_and_fail_at_the_boundary(text, held, passed):
    result = Rule.parse(text).evaluate(metrics_with_peak_forces(HUNDRED))
    assert (result.held, result.patients, result.passed) == (held, 100, passed)
    assert result.status == (0 if passed else 1)


def test_the_message_says_what_held_against_what_and_who_fared_worst():
    values = [0.0] * 10_000
    for patient in range(279):  # with 4123: 280 of 10,000 above 5 N, 97.2 % below
        values[patient * 7] = 6.0
    values[4123] = 8.1
    result = Rule.parse('peak_force_n <= 5 for 99%').evaluate(metrics_with_peak_forces(values))
    assert result.message == (
        'failed: peak_force_n <= 5 held for 97.2 % of 10,000 patients (9,720), required 99 %; '
        'worst patient 4123: 8.1 N (mcp)'
    )
    assert (result.worst_patient, result.worst_value, result.worst_joint) == (4123, 8.1, 'mcp')


def test_a_joint_less_rule_must_hold_at_every_joint_and_reports_the_failing_joint():
    result = Rule.parse('rom_fraction >= 0.8 for 50%').evaluate(accumulate([4]))
    # p0: 2/3, 1, 1 (MCP below 0.8); p1: 1, 1, 0 (DIP below): neither meets it at every joint
    assert (result.held, result.passed) == (0, False)
    assert (result.worst_patient, result.worst_value, result.worst_joint) == (1, 0.0, 'dip')
    assert result.message.endswith('worst patient 1: 0 (dip)')  # a ratio has no unit
    one_joint = Rule.parse('rom_fraction.pip >= 0.8 for 100%').evaluate(accumulate([4]))
    assert one_joint.passed
    assert one_joint.message.endswith('worst patient 0: 1')
    steps = Rule.parse('solver_warning_steps <= 1 for 50%').evaluate(accumulate([4]))
    assert steps.passed and steps.message.endswith('worst patient 1: 2 steps')
    assert steps.worst_joint is None


def test_large_values_are_shown_with_thousands_separated():
    result = Rule.parse('peak_pressure_pa <= 25000 for 100%').evaluate(accumulate([4]))
    assert result.message.endswith('worst patient 1: 30,000 Pa (mcp)')


@pytest.mark.parametrize(
    'module', [metrics, aggregates, rules], ids=lambda module: module.__name__
)
def test_the_docstring_examples_run(module):
    results = doctest.testmod(module, raise_on_error=False)
    assert results.attempted > 0, 'no docstring example ran'  # else nothing was tested
    assert results.failed == 0
