"""Session protocols (docs/trials.md, "Protocols"): targets at known times, smoothness, refusals.

Independent answers: the closed forms of each protocol written out here with math.cos per time,
the stair levels counted by hand, the simulation's time grid (step_time_ns), and a bound on the
finite differences of the smooth protocols from their largest analytic rate.
"""

import doctest
import math

import numpy as np
import pytest
from exodigit_model.gym.env import FlexExtendTarget
from exodigit_model.stepping.settings import step_time_ns
from exodigit_model.trials import (
    FUNCTIONAL_FLEXION,
    FUNCTIONAL_RANGE,
    PROTOCOLS,
    ContinuousPassiveMotion,
    GraspRelease,
    Staircase,
    make_protocol,
    protocols,
)

#: Closed forms evaluated another way agree to rounding.
EXACT = 1e-12
LOW = (0.1, 0.2, 0.0)
HIGH = (0.9, 1.0, 0.6)


def test_cpm_starts_low_peaks_high_at_half_the_period_and_returns():
    cpm = ContinuousPassiveMotion(low=LOW, high=HIGH, period=8.0)
    mid = (np.array(LOW) + np.array(HIGH)) / 2
    expected = {0.0: LOW, 2.0: mid, 4.0: HIGH, 6.0: mid, 8.0: LOW, 12.0: HIGH}
    got = cpm.targets(list(expected))
    np.testing.assert_allclose(got, list(expected.values()), rtol=0, atol=EXACT)


def test_cpm_is_the_cosine_cycle_at_any_time():
    cpm = ContinuousPassiveMotion(low=LOW, high=HIGH, period=7.0)
    times = np.linspace(0.0, 30.0, 121)
    expected = [
        [
            lo + (hi - lo) * (1.0 - math.cos(2.0 * math.pi * t / 7.0)) / 2.0
            for lo, hi in zip(LOW, HIGH, strict=True)
        ]
        for t in times
    ]
    np.testing.assert_allclose(cpm.targets(times), expected, rtol=0, atol=EXACT)


def test_staircase_levels_by_hand():
    peak = np.array([0.5, 1.0, 0.25])
    stairs = Staircase(peak=tuple(peak), stairs=5, hold=2.0)
    # stair i holds for [2i, 2i + 2): levels 0, 1, 2, 3, 4, 5, 4, 3, 2, 1 fifths, then again
    levels = {0.0: 0, 1.99: 0, 2.0: 1, 5.0: 2, 9.5: 4, 10.0: 5, 11.9: 5, 12.0: 4, 19.0: 1, 20.0: 0}
    expected = [level / 5 * peak for level in levels.values()]
    np.testing.assert_allclose(stairs.targets(list(levels)), expected, rtol=0, atol=EXACT)


def test_a_stair_starts_at_its_step_time_despite_float_rounding():
    # 0.7 / 0.1 is 6.999999999999999 in floats; t = 0.7 s is still the 8th stair (index 7),
    # level 5 − |5 − 7| = 3 fifths
    stairs = Staircase(peak=(1.0, 1.0, 1.0), stairs=5, hold=0.1, duration=2.0, rate_hz=10.0)
    np.testing.assert_allclose(stairs.targets(0.7), [0.6, 0.6, 0.6], rtol=0, atol=EXACT)
    on_grid = stairs.targets(stairs.times())  # t_k = k·0.1 s: stair k, k = 1, 2, ...
    by_hand = [5 - abs(5 - k % 10) for k in range(1, 21)]
    np.testing.assert_allclose(on_grid[:, 0], np.array(by_hand) / 5, rtol=0, atol=EXACT)


def test_grasp_closes_holds_opens_and_rests():
    grasp = GraspRelease(
        grasp=HIGH, rest=LOW, close_time=1.0, hold_time=2.0, open_time=3.0, rest_time=4.0
    )
    low, high = np.array(LOW), np.array(HIGH)
    mid = (low + high) / 2
    # cycle 10 s: closing [0, 1], held [1, 3], opening [3, 6], resting [6, 10]
    expected = {
        0.0: low,
        0.5: mid,
        1.0: high,
        2.0: high,
        3.0: high,
        4.5: mid,
        6.0: low,
        8.0: low,
        10.0: low,
        10.5: mid,
        13.0: high,
    }
    np.testing.assert_allclose(grasp.targets(list(expected)), list(expected.values()), atol=EXACT)
    # a quarter into the closing: (1 − cos(π/4))/2 of the way
    quarter = low + (high - low) * (1.0 - math.cos(math.pi / 4)) / 2
    np.testing.assert_allclose(grasp.targets(0.25), quarter, atol=EXACT)


@pytest.mark.parametrize(
    ('protocol', 'fastest'),
    [
        # largest rate of the cosine cycle: π·(high − low)/period
        (ContinuousPassiveMotion(low=LOW, high=HIGH, period=3.0), math.pi * 0.8 / 3.0),
        # the closing is half a cycle of period 2·close_time: π·(grasp − rest)/(2·close_time)
        (
            GraspRelease(grasp=HIGH, rest=LOW, close_time=0.5, open_time=2.0, rest_time=0.0),
            math.pi * 0.8 / 1.0,
        ),
    ],
    ids=['cpm', 'grasp'],
)
def test_the_smooth_protocols_are_continuous_with_a_bounded_rate(protocol, fastest):
    step = 1e-4
    times = np.arange(0.0, 20.0, step)
    rate = np.abs(np.diff(protocol.targets(times), axis=0)) / step
    assert rate.max() <= fastest * (1.0 + 1e-6)
    assert rate.max() >= fastest * 0.99  # the bound is reached: it is the rate, not a guess


def test_the_staircase_jumps_between_stairs():
    stairs = Staircase(peak=(0.5, 0.5, 0.5), stairs=5, hold=2.0)
    before, after = stairs.targets([2.0 - 1e-6, 2.0])
    np.testing.assert_allclose(after - before, [0.1, 0.1, 0.1], atol=EXACT)


def test_targets_are_vectorised_over_any_shape_of_times():
    cpm = make_protocol('cpm')
    assert cpm.targets(1.0).shape == (3,)
    assert cpm.targets(np.zeros((2, 5))).shape == (2, 5, 3)
    np.testing.assert_array_equal(cpm.targets([[1.0, 2.0]])[0, 1], cpm.targets(2.0))


#: What a protocol needs beyond its defaults: a trajectory its points.
REQUIRED = {'trajectory': {'point_times': (0.0, 2.0), 'positions': (LOW, HIGH)}}


@pytest.mark.parametrize('name', list(PROTOCOLS))
def test_a_session_is_its_duration_times_its_rate_on_the_simulations_time_grid(name):
    protocol = make_protocol(name, duration=3.0, rate_hz=50.0, **REQUIRED.get(name, {}))
    assert protocol.steps == 150
    times = protocol.times()
    expected = [step_time_ns(k, 50.0) / 1e9 for k in range(1, 151)]  # as GloveState.t
    np.testing.assert_array_equal(times, expected)
    assert times[-1] == 3.0
    assert protocol.targets(times).shape == (150, 3)


def test_the_defaults_are_the_cited_postures_and_a_one_minute_session():
    np.testing.assert_allclose(np.degrees(FUNCTIONAL_FLEXION), [61.0, 60.0, 39.0])  # Hume 1990
    np.testing.assert_allclose(
        np.degrees(FUNCTIONAL_RANGE), [[19.0, 23.0, 10.0], [71.0, 87.0, 64.0]]
    )  # Bain 2015
    cpm, stairs, grasp = (make_protocol(name) for name in ('cpm', 'staircase', 'grasp'))
    assert (cpm.low, cpm.high) == FUNCTIONAL_RANGE
    assert stairs.peak == grasp.grasp == FUNCTIONAL_FLEXION
    assert grasp.rest == (0.0, 0.0, 0.0)
    for protocol in (cpm, stairs, grasp):
        assert (protocol.duration, protocol.rate_hz, protocol.steps) == (60.0, 100.0, 6000)
    assert grasp.cycle == 10.0


def test_the_registry_lists_each_protocol_with_a_summary():
    assert list(PROTOCOLS) == ['cpm', 'staircase', 'grasp', 'trajectory']
    for name, kind in PROTOCOLS.items():
        assert kind.summary, name
        assert isinstance(make_protocol(name, **REQUIRED.get(name, {})), kind)


def test_the_gym_target_is_the_cpm_cycle_from_the_straight_finger():
    target = FlexExtendTarget(HIGH, period=4.0)
    cpm = ContinuousPassiveMotion(low=(0.0, 0.0, 0.0), high=HIGH, period=4.0)
    for t in (0.0, 0.3, 1.0, 2.0, 3.7):
        np.testing.assert_array_equal(target(t), cpm.targets(t))


# -- refusals -------------------------------------------------------------------------------


@pytest.mark.parametrize(
    ('name', 'parameters', 'message'),
    [
        ('cpm', {'duration': 0.0}, r'duration = 0.0: must be > 0 \(s\)'),
        ('cpm', {'duration': -1.0}, 'duration = -1.0: must be > 0'),
        ('cpm', {'duration': float('nan')}, 'duration = nan: must be finite'),
        ('cpm', {'duration': '60'}, "duration = '60': must be a number"),
        ('cpm', {'rate_hz': 0.0}, r'rate_hz = 0.0: must be > 0 \(Hz\)'),
        ('cpm', {'duration': 0.015}, 'is 1.5 steps: must be a whole number of steps'),
        ('cpm', {'duration': 0.001}, 'is 0.1 steps: must be a whole number of steps, at least 1'),
        (
            'cpm',
            {'low': (0.0, 0.0)},
            r'low must be three numbers \(MCP, PIP, DIP\), got shape \(2,\)',
        ),
        ('cpm', {'high': (0.0, math.inf, 0.0)}, 'high must be finite'),
        ('cpm', {'period': 0.0}, 'period = 0.0: must be > 0'),
        ('staircase', {'stairs': 0}, 'stairs = 0: must be a whole number >= 1'),
        ('staircase', {'stairs': 2.5}, 'stairs = 2.5: must be a whole number'),
        ('staircase', {'stairs': True}, 'stairs = True: must be a whole number'),
        ('staircase', {'hold': 0.0}, 'hold = 0.0: must be > 0'),
        ('staircase', {'peak': 'high'}, 'peak'),
        ('grasp', {'close_time': 0.0}, 'close_time = 0.0: must be > 0'),
        ('grasp', {'open_time': -2.0}, 'open_time = -2.0: must be > 0'),
        ('grasp', {'hold_time': -1.0}, 'hold_time = -1.0: must be >= 0'),
        ('grasp', {'rest_time': math.inf}, 'rest_time = inf: must be finite'),
        ('grasp', {'rest': (0.0, 0.0, math.nan)}, 'rest must be finite'),
        ('grasp', {'perod': 1.0}, "unknown parameter 'perod' \\(known: duration, rate_hz, "),
        ('sine', {}, "protocol 'sine': unknown \\(known: cpm, staircase, grasp, trajectory\\)"),
        ('trajectory', {'point_times': (0.0,)}, "protocol 'trajectory': parameter 'positions'"),
        (
            'trajectory',
            {'point_times': (0.0, 0.0), 'positions': (LOW, HIGH)},
            r'\(point_times, positions\): times: point 1 at 0.0 s is not after point 0',
        ),
        (
            'trajectory',
            {'point_times': (0.0, 1.0), 'positions': (LOW, HIGH), 'velocities': (LOW,)},
            r'velocities: shape \(1, 3\), must be \(2, 3\)',
        ),
    ],
)
def test_bad_parameters_are_refused_naming_the_field(name, parameters, message):
    with pytest.raises(ValueError, match=message):
        make_protocol(name, **parameters)


@pytest.mark.parametrize('times', [-0.1, [0.0, math.nan], math.inf, 'soon'])
def test_targets_refuse_times_that_are_not_finite_and_non_negative(times):
    with pytest.raises(ValueError, match='must be finite times >= 0 s'):
        make_protocol('grasp').targets(times)


def test_the_docstring_examples_run():
    results = doctest.testmod(protocols, raise_on_error=False)
    assert results.attempted > 0, 'no docstring example ran'  # else nothing was tested
    assert results.failed == 0
