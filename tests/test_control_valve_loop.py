"""The valve pressure loop (exodigit_model.control.ValveLoop; no ROS, fast).

The loop is checked on toy chambers whose answer is known in closed form: an integrating
chamber p ← p + g·(u_in − u_out) (fixed volume, flow proportional to the opening), on which a
proportional loop's error shrinks by (1 − kp·g) a step.
"""

import math

import numpy as np
import pytest
from exodigit_model.control import (
    MODE_DEFAULTS,
    CommandLoop,
    Feedback,
    SafetyLimiter,
    SafetyLimits,
    Staircase,
    ValveLoop,
    ValveLoopSettings,
)
from exodigit_model.stepping.settings import CLOSED, VENT

from exodigit_model import GloveSimulation

DT = 0.01
"""Step of the loop, s (the plant's 100 Hz)."""
EXACT = 1e-12
"""Relative tolerance of closed-form comparisons (floating-point rounding only)."""


def chamber_run(loop, target, gain, steps, p0=0.0, leak=0.0):
    """Pressures and openings of three integrating chambers under ``loop`` (Pa, per step).

    Each step: p ← p + gain·(u_in − u_out) − leak (Pa per step), with the openings computed
    from the pressure at the step's start.
    """
    target = np.broadcast_to(np.asarray(target, float), (3,))
    p = np.full(3, p0)
    pressures, openings = [], []
    for _ in range(steps):
        u = loop.openings(target, p, DT)
        p = p + np.asarray(gain) * (u[:3] - u[3:]) - leak
        pressures.append(p)
        openings.append(u)
    return np.array(pressures), np.array(openings)


def test_settings_refuse_bad_values_naming_the_field():
    with pytest.raises(ValueError, match=r'valve_deadband = -1\.0: must be finite and >= 0'):
        ValveLoopSettings(valve_deadband=-1.0)
    with pytest.raises(ValueError, match=r'valve_kp = 0\.0: must be > 0'):
        ValveLoopSettings(valve_kp=0.0)
    with pytest.raises(ValueError, match='valve_ki = nan'):
        ValveLoopSettings(valve_ki=math.nan)
    with pytest.raises(ValueError, match="valve_ki = '1': must be a number"):
        ValveLoopSettings(valve_ki='1')


def test_proportional_openings_fill_below_and_vent_above_the_target():
    loop = ValveLoop(ValveLoopSettings(valve_deadband=100.0, valve_kp=1e-4, valve_ki=0.0))
    u = loop.openings(np.array([20e3, 20e3, 20e3]), np.array([16e3, 23e3, 20.05e3]), DT)
    # MCP 4 kPa low: inlet 0.4; PIP 3 kPa high: outlet 0.3; DIP within 100 Pa: hold
    np.testing.assert_allclose(u, [0.4, 0.0, 0.0, 0.0, 0.3, 0.0], rtol=EXACT)


def test_a_chamber_within_the_deadband_holds_and_a_zero_target_vents():
    loop = ValveLoop(ValveLoopSettings(valve_deadband=300.0))
    np.testing.assert_array_equal(
        loop.openings(np.full(3, 10e3), np.array([9.8e3, 10e3, 10.299e3]), DT), CLOSED
    )
    np.testing.assert_array_equal(loop.openings(np.zeros(3), np.full(3, 50.0), DT), VENT)
    np.testing.assert_array_equal(loop.openings(np.zeros(3), np.zeros(3), DT), VENT)


def test_a_proportional_loop_shrinks_the_error_geometrically_into_the_deadband():
    """With ki = 0 on an integrating chamber: e_k = e_0·(1 − kp·g)^k until |e| ≤ deadband."""
    kp, gain, deadband = 1 / 40e3, np.array([16e3, 24e3, 37e3]), 300.0
    loop = ValveLoop(ValveLoopSettings(valve_deadband=deadband, valve_kp=kp, valve_ki=0.0))
    target = 30e3
    pressures, openings = chamber_run(loop, target, gain, 60)
    error = target - pressures
    factor = 1.0 - kp * gain
    for joint in range(3):
        closed_form = target * factor[joint] ** np.arange(1, 61)
        outside = np.abs(closed_form) > deadband
        last = np.argmin(outside)  # the step the error enters the deadband
        np.testing.assert_allclose(
            error[: last + 1, joint], closed_form[: last + 1], rtol=1e-9, atol=1e-9
        )
        assert np.all(error[last:, joint] == error[last, joint])  # then it holds
        assert abs(error[-1, joint]) <= deadband
    assert np.all((openings[:, :3] == 0.0) | (openings[:, 3:] == 0.0))  # never both open


def test_the_integral_takes_a_leak_off_and_does_not_wind_up_against_the_clip():
    """A chamber leaking 200 Pa a step (20 kPa/s) is held near its target only with the integral.

    A P loop holds a chamber that leaks where kp·g·e equals the leak: e = 200/(kp·g) = 500 Pa,
    beyond the deadband, exactly. The PI loop's integral brings the mean error inside the
    deadband (the hold lets the chamber leak out of it, and the integral refills it: the error
    swings by about a kilopascal either side, module text). Saturated for its first steps (far
    target, slow chamber), the integral must not wind up: the first approach overshoots by less
    than one step's fill.
    """
    gain, leak = 16e3, 200.0
    p_only = ValveLoop(ValveLoopSettings(valve_deadband=300.0, valve_kp=1 / 40e3, valve_ki=0.0))
    pressures, _ = chamber_run(p_only, 30e3, gain, 300, leak=leak)
    np.testing.assert_allclose(30e3 - pressures[-50:], leak / (gain / 40e3), rtol=1e-6)

    settings = ValveLoopSettings(valve_deadband=300.0, valve_kp=1 / 40e3, valve_ki=1 / 40e3)
    pressures, _ = chamber_run(ValveLoop(settings), 30e3, gain, 1000, leak=leak)
    error = 30e3 - pressures[-300:]
    assert abs(error.mean()) < 300.0
    assert np.abs(error).max() < 1500.0
    slow = ValveLoop(settings)
    pressures, openings = chamber_run(slow, 60e3, 500.0, 400)
    assert np.all(openings[:20, :3] == 1.0)  # far target, slow chamber: fully open
    assert pressures.max() - 60e3 < 500.0  # no wound-up integral pushing it far past


def test_reset_forgets_the_integral_and_configure_takes_new_gains():
    loop = ValveLoop(ValveLoopSettings(valve_deadband=0.0, valve_kp=1e-5, valve_ki=1e-3))
    for _ in range(10):
        loop.openings(np.full(3, 10e3), np.full(3, 9e3), DT)
    first = loop.openings(np.full(3, 10e3), np.full(3, 9e3), DT)
    loop.reset()
    fresh = loop.openings(np.full(3, 10e3), np.full(3, 9e3), DT)
    # fresh: kp·e + ki·e·dt = 0.01 + 1e-3·1e3·0.01
    np.testing.assert_allclose(fresh[:3], 0.01 + 0.01, rtol=EXACT)
    assert np.all(first[:3] > fresh[:3])
    loop.reset()
    loop.configure(ValveLoopSettings(valve_deadband=0.0, valve_kp=2e-5, valve_ki=0.0))
    np.testing.assert_allclose(
        loop.openings(np.full(3, 10e3), np.full(3, 9e3), DT)[:3], 0.02, rtol=EXACT
    )


def test_a_batch_loop_is_one_loop_per_glove_row_by_row():
    """``count=N`` keeps an integral per glove: row n equals a one-glove loop fed row n alone."""
    settings = ValveLoopSettings(valve_deadband=300.0, valve_kp=1 / 40e3, valve_ki=1 / 4e3)
    rng = np.random.default_rng(7)
    targets = np.array([[30e3, 0.0, 10e3], [5e3, 20e3, 40e3]])
    batch = ValveLoop(settings, count=2)
    singles = [ValveLoop(settings), ValveLoop(settings)]
    for _ in range(3):  # three steps, then a reset: each starts every row over
        for _ in range(3):
            measured = rng.uniform(0.0, 45e3, size=(2, 3))
            together = batch.openings(targets, measured, DT)
            assert together.shape == (2, 6)
            for n, single in enumerate(singles):
                np.testing.assert_array_equal(
                    together[n], single.openings(targets[n], measured[n], DT)
                )
        batch.reset()
        for single in singles:
            single.reset()


def test_the_vent_and_closed_openings_cannot_be_changed_in_place():
    """Every node and trial shares these two arrays: a write would change them all."""
    for openings in (VENT, CLOSED):
        with pytest.raises(ValueError, match='read-only'):
            openings[0] = 0.5


# -- on the default glove (GloveSimulation(actuation='valves')) ------------------------------


def test_the_default_gain_makes_no_chamber_overshoot_within_one_step_of_the_default_glove():
    """kp times the largest pressure change of one fully open step stays below 1 (module text).

    The largest change is an inlet's from rest (a chamber fills slower as it swells and nears
    the supply): if the model's chambers fill faster, or kp is raised, this fails.
    """
    kp = ValveLoopSettings().valve_kp
    for openings in ([1.0, 1.0, 1.0, 0.0, 0.0, 0.0], [0.2, 0.2, 0.2, 0.0, 0.0, 0.0]):
        simulation = GloveSimulation(actuation='valves')
        for _ in range(10):  # one step from rest, then nine from ever higher pressures
            before = simulation.state.pressure
            change = simulation.step(openings).pressure - before
            assert np.all(kp * change / openings[0] < 1.0)


def test_the_default_loop_settles_every_stair_of_the_staircase_within_the_deadband():
    """The staircase mode through the limiter and the loop: the last second of each 2 s stair
    lies within the deadband of its level, and no chamber alternates filling and venting."""
    defaults = MODE_DEFAULTS['staircase']
    mode = Staircase(defaults['staircase_step'], defaults['staircase_peak'], 2.0)
    command = CommandLoop(mode, SafetyLimiter(SafetyLimits()))
    settings = ValveLoopSettings()
    loop, simulation = ValveLoop(settings), GloveSimulation(actuation='valves')
    state, period = simulation.state, simulation.period
    levels, pressures, openings = [], [], []
    for k in range(2000):  # 20 s: up to 50 kPa and back to 10 kPa
        target = command.command(k * period, period, Feedback(state.q_measured, None)).pressure
        u = loop.openings(target, state.pressure_measured, period)
        state = simulation.step(u)
        levels.append(mode.levels[k // 200]), pressures.append(state.pressure), openings.append(u)
    settled = np.arange(2000) % 200 >= 100
    error = np.array(levels)[:, None] - np.array(pressures)
    assert np.abs(error[settled]).max() <= settings.valve_deadband
    u = np.array(openings)
    swaps = (u[:-1, :3] > 0) & (u[1:, 3:] > 0) | (u[:-1, 3:] > 0) & (u[1:, :3] > 0)
    assert swaps.sum(axis=0).max() <= 2  # at the peak's turn only
