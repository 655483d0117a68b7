"""Joint trajectories (exodigit_model.control.trajectory): sampling, the setpoint, refusals.

Independent answers: the targets at and between points worked out by hand (a straight line, and
the cubic Hermite polynomial's values at u = 1/2, p = (p_a + p_b)/2 + h·(v_a − v_b)/8, with its
slopes at the ends by finite differences), the protocols' own target functions, and a setpoint
placed at an absolute start of 10^18 ns (a wall-clock stamp) against the trajectory sampled from
its start.
"""

import math

import numpy as np
import pytest
from exodigit_model.control import Setpoint, Trajectory, TrajectoryError
from exodigit_model.control.trajectory import MAX_POINTS, MAX_TIME
from exodigit_model.stepping.settings import step_time_ns
from exodigit_model.trials import TrialSpec, make_protocol

SECOND = 10**9
P0, P1, P2 = (0.0, 0.0, 0.0), (1.0, 0.5, 0.2), (0.4, 1.5, 0.2)
#: Three points at 0, 2 and 5 s, positions only.
LINE = Trajectory([0.0, 2.0, 5.0], [P0, P1, P2])


def test_positions_only_are_the_points_at_their_times_and_straight_lines_between():
    for t, point in ((0.0, P0), (2.0, P1), (5.0, P2)):
        np.testing.assert_array_equal(LINE.at(t), point)
    # by hand: halfway to P1, and halfway from P1 to P2
    np.testing.assert_allclose(LINE.at(1.0), [0.5, 0.25, 0.1], rtol=0, atol=1e-15)
    np.testing.assert_allclose(LINE.at(3.5), [0.7, 1.0, 0.2], rtol=0, atol=1e-15)
    # a quarter of the way from P1 to P2 (2.75 s)
    np.testing.assert_allclose(LINE.at(2.75), [0.85, 0.75, 0.2], rtol=0, atol=1e-15)


def test_before_the_first_point_it_holds_the_first_and_after_the_last_the_last():
    late = Trajectory([1.0, 2.0], [P1, P2])
    np.testing.assert_array_equal(late.at(0.0), P1)
    np.testing.assert_array_equal(late.at(0.5), P1)
    np.testing.assert_array_equal(late.at(9.0), P2)
    assert late.at(np.zeros((2, 4))).shape == (2, 4, 3)


def test_with_velocities_a_segment_is_the_cubic_hermite_polynomial():
    v0, v1 = np.array([1.0, 0.0, 0.0]), np.array([0.0, 0.0, -1.0])
    cubic = Trajectory([0.0, 2.0], [P0, (1.0, 1.0, 1.0)], velocities=[v0, v1])
    h = 2.0
    # at u = 1/2: the mean of the ends plus h (v_a − v_b) / 8
    np.testing.assert_allclose(cubic.at(1.0), 0.5 + h * (v0 - v1) / 8, rtol=0, atol=1e-15)
    np.testing.assert_array_equal(cubic.at(0.0), P0)
    np.testing.assert_array_equal(cubic.at(2.0), [1.0, 1.0, 1.0])
    # its slopes at the ends are the velocities given (one-sided differences)
    d = 1e-6
    np.testing.assert_allclose((cubic.at(d) - cubic.at(0.0)) / d, v0, atol=1e-5)
    np.testing.assert_allclose((cubic.at(2.0) - cubic.at(2.0 - d)) / d, v1, atol=1e-5)


def test_a_protocols_trajectory_gives_its_targets_exactly_at_every_step():
    for name in ('cpm', 'grasp', 'staircase'):
        protocol = make_protocol(name, duration=3.0)
        times, path = protocol.times(), protocol.trajectory()
        sampled = [path.at_ns(step_time_ns(k, protocol.rate_hz)) for k in range(1, 301)]
        np.testing.assert_array_equal(sampled, protocol.targets(times))
        np.testing.assert_array_equal(path.at(times), protocol.targets(times))


def test_an_absolute_start_gives_the_same_targets_bit_for_bit():
    # What a node does (absolute stamps of a wall clock, ns since 1970) and what an in-process
    # session does (ns from its start) give the same numbers between points too.
    cubic = Trajectory(
        [0.0, 0.3, 1.1], [P0, P1, P2], velocities=[(0.0, 0.1, 0.0), (1.0, -1.0, 0.5), P0]
    )
    start = 10**18 + 123_456_789
    setpoint = Setpoint(P0)
    setpoint.place(cubic, start, now_ns=start - SECOND)
    for t_ns in range(0, 1_300_000_000, 7_000_001):
        np.testing.assert_array_equal(setpoint.at(start + t_ns), cubic.at_ns(t_ns))


# -- the setpoint: trajectories placed, replaced, and over a reset ------------------------------


def test_a_trajectory_replaces_the_rest_of_the_old_one_from_its_start():
    setpoint = Setpoint(P0)
    setpoint.place(LINE, 10 * SECOND, now_ns=10 * SECOND)
    replacement = Trajectory([1.0], [P2])  # one point 1 s after its start
    setpoint.place(replacement, 13 * SECOND, now_ns=11 * SECOND)
    # until its start the old one goes on, exactly
    for t in (11.0, 12.0, 12.999):
        np.testing.assert_array_equal(setpoint.at(round(t * SECOND)), LINE.at(t - 10.0))
    # from its start a line from the target in force then (LINE at 3 s) to its point
    then = LINE.at(3.0)
    np.testing.assert_array_equal(setpoint.at(13 * SECOND), then)
    np.testing.assert_allclose(setpoint.at(13 * SECOND + SECOND // 2), (then + P2) / 2, atol=1e-15)
    np.testing.assert_array_equal(setpoint.at(14 * SECOND), P2)
    np.testing.assert_array_equal(setpoint.at(100 * SECOND), P2)  # held after its end


def test_a_zero_stamp_starts_on_receipt_and_a_first_point_at_zero_jumps():
    setpoint = Setpoint(P0)
    setpoint.place(Trajectory.hold(P1), None, now_ns=5 * SECOND)
    np.testing.assert_array_equal(setpoint.at(5 * SECOND - 1), P0)
    np.testing.assert_array_equal(setpoint.at(5 * SECOND), P1)


def test_velocities_bend_the_segments_between_points_not_the_way_to_the_first():
    cubic = Trajectory([1.0, 2.0], [P1, P2], velocities=[(1.0, 1.0, 1.0), (0.0, 0.0, 0.0)])
    setpoint = Setpoint(P0)
    setpoint.place(cubic, SECOND, now_ns=0)
    # from the target in force (P0) to the first point: a straight line
    middle = setpoint.at(SECOND + SECOND // 2)
    np.testing.assert_allclose(middle, (np.array(P0) + P1) / 2, atol=1e-15)
    np.testing.assert_array_equal(setpoint.at(3 * SECOND), cubic.at(2.0))
    np.testing.assert_array_equal(setpoint.at(2 * SECOND + SECOND // 2), cubic.at(1.5))


def test_over_a_reset_a_stamped_trajectory_keeps_its_start_and_a_zero_stamped_one_restarts():
    # The testing kit sends the next session's trajectory, stamped in that session's time,
    # before the session starts: a reset at 0.01 s (time went back from 10 s) keeps it.
    setpoint = Setpoint(P0)
    setpoint.place(LINE, 10_000_000, now_ns=10 * SECOND)
    setpoint.restart(P2, now_ns=10_000_000)
    for t in (0.0, 1.0, 3.5, 7.0):
        np.testing.assert_array_equal(setpoint.at(10_000_000 + round(t * SECOND)), LINE.at(t))
    # one stamped zero (joint_targets, or a trajectory "from receipt") starts again at the
    # reset, from the target in force then
    setpoint.place(Trajectory([2.0], [P1]), None, now_ns=20 * SECOND)
    setpoint.restart(P2, now_ns=SECOND)
    np.testing.assert_array_equal(setpoint.at(SECOND), P2)
    np.testing.assert_allclose(setpoint.at(2 * SECOND), (np.array(P2) + P1) / 2, atol=1e-15)
    np.testing.assert_array_equal(setpoint.at(3 * SECOND), P1)
    # a hold stays a hold
    setpoint.hold(P1)
    setpoint.restart(P2, now_ns=0)
    np.testing.assert_array_equal(setpoint.at(5 * SECOND), P1)


def test_what_is_over_is_dropped():
    setpoint = Setpoint(P0)
    for k in range(100):  # a trajectory every second, each replacing the one before
        setpoint.place(LINE, k * SECOND, now_ns=k * SECOND)
    assert len(setpoint._pieces) <= 2


# -- refusals -------------------------------------------------------------------------------


@pytest.mark.parametrize(
    ('times', 'positions', 'velocities', 'rule', 'message'),
    [
        ([], np.zeros((0, 3)), None, 'no points', 'at least one point'),
        (
            np.arange(MAX_POINTS + 1.0),
            np.zeros((MAX_POINTS + 1, 3)),
            None,
            'too many points',
            '100,001 points, at most 100,000',
        ),
        ([0.0, 1.0], [P0], None, 'shape', r'positions: shape \(1, 3\), must be \(2, 3\)'),
        ([0.0], [(0.0, 0.0)], None, 'shape', r'positions: shape \(1, 2\)'),
        ([[0.0]], [P0], None, 'shape', r'times: shape \(1, 1\)'),
        (['soon'], [P0], None, 'times', 'times: must be numbers'),
        ([0.0, 1.0], [P0, (0.0, math.nan, 0.0)], None, 'non-finite', 'positions: point 1'),
        ([0.0], [P0], [(math.inf, 0.0, 0.0)], 'non-finite', 'velocities: point 0'),
        ([0.0], [P0], [P0, P0], 'shape', r'velocities: shape \(2, 3\), must be \(1, 3\)'),
        ([-0.5], [P0], None, 'times', r'point 0 at -0.5 s, must be in 0 .. 1e\+06 s'),
        ([MAX_TIME * 2], [P0], None, 'times', 'point 0 at 2000000.0 s'),
        ([math.nan], [P0], None, 'times', 'point 0 at nan s'),
        ([0.0, 2.0, 1.0], [P0, P1, P2], None, 'times', 'point 2 at 1.0 s is not after point 1'),
        ([1.0, 1.0 + 1e-10], [P0, P1], None, 'times', 'is not after'),  # the same nanosecond
    ],
)
def test_a_trajectory_that_breaks_a_rule_is_refused_naming_it(
    times, positions, velocities, rule, message
):
    with pytest.raises(TrajectoryError, match=message) as refusal:
        Trajectory(times, positions, velocities)
    assert refusal.value.rule == rule
    assert isinstance(refusal.value, ValueError)


def test_points_outside_the_range_of_motion_are_refused_naming_the_first():
    with pytest.raises(TrajectoryError, match=r'point 2 at 5 s, \[0.4, 1.5, 0.2\] rad') as refusal:
        LINE.check_range((-0.1, -0.1, -0.1), (1.57, 1.4, 1.4))
    assert refusal.value.rule == 'out of range'
    LINE.check_range((-0.1, -0.1, -0.1), (1.57, 1.75, 1.4))  # inside: nothing


# -- the in-process side: GloveEnv and the trials take a trajectory --------------------------


def test_glove_env_takes_a_trajectory_for_its_target():
    gym = pytest.importorskip('exodigit_model.gym')
    path = Trajectory([0.0, 0.5, 1.0], [P0, (0.3, 0.2, 0.1), (0.1, 0.4, 0.2)])
    as_function = gym.GloveEnv(episode_steps=100, target=lambda t: path.at(t))
    as_trajectory = gym.GloveEnv(episode_steps=100, target=path)
    for env in (as_function, as_trajectory):
        env.reset(seed=0)
    for k in range(1, 101):
        info = [env.step([0.0, 0.0, 0.0])[4] for env in (as_function, as_trajectory)]
        np.testing.assert_array_equal(info[1]['target'], path.at_ns(step_time_ns(k, 100.0)))
        np.testing.assert_array_equal(info[0]['target'], info[1]['target'])


def test_a_trial_follows_a_trajectory_protocol_and_scores_against_its_samples():
    from exodigit_model.trials import ControllerSpec, run_trial
    from exodigit_model.trials.trial import record_patient

    points = {'point_times': (0.0, 0.4, 1.0), 'positions': (P0, (0.6, 0.7, 0.4), (0.2, 0.3, 0.1))}
    spec = TrialSpec(
        patients=2,
        protocol='trajectory',
        protocol_parameters={'duration': 1.0, **points},
        controller=ControllerSpec('mode', 'position'),
    )
    result = run_trial(spec)
    # the PIP's targets from t_1 = 0.01 s (0.7 · 0.01/0.4 rad) to the 0.7 rad at 0.4 s
    assert result.metrics.values['target_rom_rad'][:, 1] == pytest.approx(0.7 - 0.7 * 0.01 / 0.4)
    record = record_patient(spec, 1)
    path = Trajectory(points['point_times'], points['positions'])
    np.testing.assert_array_equal(record.target, path.at(spec.session().times()))
