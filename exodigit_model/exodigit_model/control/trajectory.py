"""Joint trajectories: the timed targets of the position mode, and the targets in force over time.

A :class:`Trajectory` is what ``pressure_command`` takes on ``joint_trajectory``
(trajectory_msgs/JointTrajectory, as ros2_control's joint_trajectory_controller takes it;
docs/spec/ros.md, "Trajectories") and what :class:`~exodigit_model.gym.env.GloveEnv`, the trials
(the ``trajectory`` protocol) and the testing kit take where they take a target function: points
at times from its start, each with positions and optionally velocities (rad, rad/s; MCP, PIP,
DIP). The ROS node and the in-process side sample it with the one function here, so a node and
an in-process session that ask for the same time get the same targets, bit for bit.

Sampling at time t: between two points linearly, or, where both points have velocities, along
the cubic Hermite polynomial of their positions and velocities (ros2_control's spline for
positions, and for positions with velocities); before the first point its position, after the
last point the last position (held). Times are whole nanoseconds, ROS's unit: a time in seconds
is rounded to the nearest one (exact up to :data:`MAX_TIME`), and the share of a segment is the
quotient of two whole-nanosecond differences, so absolute stamps (the node) and times from a
session's start (in process) give the same numbers.

A :class:`Setpoint` is the node's target over time: a hold, with trajectories placed into it,
each replacing the rest of what was in force from its start, and what to do when time goes back.
"""

from __future__ import annotations

import bisect
import math
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import ArrayLike, NDArray

NANOSECONDS = 10**9
MAX_POINTS = 100_000
"""Most points of a trajectory: a quarter of an hour at one point per 10 ms step (what the
testing kit sends is one point a step); about 5 MB as a JointTrajectory message."""
MAX_TIME = 1e6
"""Latest time of a point from the trajectory's start, s (11.6 days): below it a time in seconds
and its nanoseconds convert both ways exactly."""


class TrajectoryError(ValueError):
    """A trajectory breaks a rule; ``rule`` is a short key (for counts), the text says why."""

    def __init__(self, rule: str, detail: str) -> None:
        super().__init__(detail)
        self.rule = rule


def _finite_rows(name: str, value: ArrayLike, count: int) -> NDArray[np.float64]:
    """``value`` as a read-only finite float array of shape (``count``, 3)."""
    try:
        rows = np.array(value, dtype=float)
    except (TypeError, ValueError):
        raise TrajectoryError(
            'shape', f'{name}: must be rows of 3 numbers (MCP, PIP, DIP)'
        ) from None
    if rows.shape != (count, 3):
        raise TrajectoryError('shape', f'{name}: shape {rows.shape}, must be ({count}, 3)')
    bad = np.flatnonzero(~np.isfinite(rows).all(axis=1))
    if bad.size:
        raise TrajectoryError(
            'non-finite',
            f'{name}: point {bad[0]} holds a non-finite value {rows[bad[0]].tolist()}',
        )
    rows.flags.writeable = False
    return rows


@dataclass(frozen=True, eq=False)
class Trajectory:
    """Joint targets at times from a start: sampled by :meth:`at` or called as ``q*(t)``.

    Attributes
    ----------
    times : ndarray, shape (n,)
        Time of each point from the trajectory's start, s: strictly increasing (in whole
        nanoseconds), from 0 up to :data:`MAX_TIME`; 1 <= n <= :data:`MAX_POINTS`.
    positions : ndarray, shape (n, 3)
        Joint angles of each point, rad (MCP, PIP, DIP).
    velocities : ndarray, shape (n, 3), optional
        Joint speeds of each point, rad/s; None: positions only (linear segments).
    times_ns : tuple of int
        ``times`` in whole nanoseconds (what sampling uses).

    Raises
    ------
    TrajectoryError
        A ValueError naming the field, the point and the rule (its ``rule``: ``'no points'``,
        ``'too many points'``, ``'shape'``, ``'non-finite'``, ``'times'``).

    Examples
    --------
    >>> close = Trajectory([0.0, 2.0], [[0.0, 0.0, 0.0], [1.0, 1.2, 0.6]])
    >>> close.at(1.0).tolist()
    [0.5, 0.6, 0.3]
    """

    times: NDArray[np.float64]
    positions: NDArray[np.float64]
    velocities: NDArray[np.float64] | None = None
    times_ns: tuple[int, ...] = field(init=False, repr=False)

    def __post_init__(self) -> None:
        """Check every rule (class text) and keep read-only arrays."""
        try:
            times = np.array(self.times, dtype=float)
        except (TypeError, ValueError):
            raise TrajectoryError('times', 'times: must be numbers, s') from None
        if times.ndim != 1:
            raise TrajectoryError('shape', f'times: shape {times.shape}, must be (n,)')
        if times.size == 0:
            raise TrajectoryError('no points', 'times: a trajectory needs at least one point')
        if times.size > MAX_POINTS:
            raise TrajectoryError(
                'too many points', f'times: {times.size:,} points, at most {MAX_POINTS:,}'
            )
        positions = _finite_rows('positions', self.positions, times.size)
        velocities = None
        if self.velocities is not None:
            velocities = _finite_rows('velocities', self.velocities, times.size)
        outside = np.flatnonzero(~(np.isfinite(times) & (times >= 0.0) & (times <= MAX_TIME)))
        if outside.size:
            k = outside[0]
            raise TrajectoryError(
                'times',
                f'times: point {k} at {float(times[k])!r} s, must be in 0 .. {MAX_TIME:g} s',
            )
        seconds = times.tolist()
        times_ns = tuple(round(t * NANOSECONDS) for t in seconds)
        for k in range(1, len(times_ns)):
            if times_ns[k] <= times_ns[k - 1]:
                raise TrajectoryError(
                    'times',
                    f'times: point {k} at {seconds[k]!r} s is not after point {k - 1} at '
                    f'{seconds[k - 1]!r} s: times must increase',
                )
        times.flags.writeable = False
        for name, value in (
            ('times', times),
            ('positions', positions),
            ('velocities', velocities),
        ):
            object.__setattr__(self, name, value)
        object.__setattr__(self, 'times_ns', times_ns)

    @classmethod
    def hold(cls, positions: ArrayLike) -> Trajectory:
        """One point at the start: ``positions`` (rad) from then on."""
        return cls([0.0], [positions])

    @property
    def duration(self) -> float:
        """Time of the last point, s."""
        return float(self.times[-1])

    def check_range(self, lower: ArrayLike, upper: ArrayLike) -> None:
        """Refuse a point outside the range of motion ``lower`` .. ``upper`` (rad, per joint).

        Raises
        ------
        TrajectoryError
            With ``rule`` ``'out of range'``, naming the first point outside.
        """
        outside = np.flatnonzero(((self.positions < lower) | (self.positions > upper)).any(axis=1))
        if outside.size:
            k = outside[0]
            raise TrajectoryError(
                'out of range',
                f'positions: point {k} at {self.times[k]:g} s, {self.positions[k].tolist()} rad, '
                f'is outside the range of motion {list(lower)} .. {list(upper)} rad',
            )

    def at_ns(self, t_ns: int) -> NDArray[np.float64]:
        """The targets ``t_ns`` whole nanoseconds from the start, rad, (3,) (a new array)."""
        return sample(self.times_ns, self.positions, self.velocities, t_ns)

    def at(self, t: ArrayLike) -> NDArray[np.float64]:
        """The targets at times ``t`` from the start (s, any shape), rad: ``t.shape + (3,)``."""
        times = np.asarray(t, dtype=float)
        rows = [self.at_ns(round(value * NANOSECONDS)) for value in times.reshape(-1).tolist()]
        return np.array(rows).reshape((*times.shape, 3))

    __call__ = at


def sample(
    times_ns: list[int] | tuple[int, ...],
    positions: NDArray[np.float64],
    velocities: NDArray[np.float64] | None,
    t_ns: int,
) -> NDArray[np.float64]:
    """The one interpolation (module text) of points at ``times_ns`` (increasing) at ``t_ns``.

    ``velocities`` None (positions only), or (n, 3) with NaN rows for points without them.
    """
    after = bisect.bisect_right(times_ns, t_ns)
    if after == 0:
        return positions[0].copy()
    if after == len(times_ns):
        return positions[-1].copy()
    a, b = after - 1, after
    span = times_ns[b] - times_ns[a]
    u = (t_ns - times_ns[a]) / span
    if velocities is None or math.isnan(velocities[a, 0]) or math.isnan(velocities[b, 0]):
        return positions[a] + u * (positions[b] - positions[a])
    h = span / NANOSECONDS  # the segment's length, s (Hermite basis in u, slopes times h)
    u2, u3 = u * u, u * u * u
    return (
        (2.0 * u3 - 3.0 * u2 + 1.0) * positions[a]
        + (u3 - 2.0 * u2 + u) * h * velocities[a]
        + (3.0 * u2 - 2.0 * u3) * positions[b]
        + (u3 - u2) * h * velocities[b]
    )


class Setpoint:
    """The joint targets in force over the time of a clock (ns): what the position mode tracks.

    A hold of some targets at first; :meth:`place` puts a trajectory in from its start time on,
    replacing the rest of what was in force from then: before its start what was there goes on,
    from its start to its first point the target moves linearly from the target in force at the
    start, then it follows the trajectory's points, and after its last point it holds it.

    Parameters
    ----------
    targets : array_like, shape (3,)
        The targets held at first, rad.
    """

    def __init__(self, targets: ArrayLike) -> None:
        self.hold(targets)

    def hold(self, targets: ArrayLike) -> None:
        """Hold ``targets`` (rad) at every time: forget every trajectory placed."""
        trajectory = Trajectory.hold(targets)
        self._starts = [-(2**63)]
        self._pieces = [((0,), trajectory.positions, None)]
        self.latest: tuple[Trajectory, int | None] = (trajectory, None)
        """The trajectory placed last and its start (ns; None: from whenever it is placed)."""

    def place(self, trajectory: Trajectory, start_ns: int | None, now_ns: int) -> None:
        """``trajectory`` from ``start_ns`` on (None: from ``now_ns``, as a zero stamp means).

        What was in force before the start stays as it was; what is over by ``now_ns`` is
        dropped (nothing samples the past).
        """
        start = now_ns if start_ns is None else start_ns
        times = [start + t for t in trajectory.times_ns]
        positions, velocities = trajectory.positions, trajectory.velocities
        if times[0] > start:  # from the target in force at the start to the first point
            times.insert(0, start)
            positions = np.concatenate([self.at(start)[np.newaxis], positions])
            if velocities is not None:
                velocities = np.concatenate([np.full((1, 3), np.nan), velocities])
        first = max(bisect.bisect_right(self._starts, min(now_ns, start)) - 1, 0)
        last = bisect.bisect_left(self._starts, start)
        self._starts = [*self._starts[first:last], start]
        self._pieces = [*self._pieces[first:last], (tuple(times), positions, velocities)]
        self.latest = (trajectory, start_ns)

    def restart(self, targets: ArrayLike, now_ns: int) -> None:
        """Time went back to ``now_ns``: hold ``targets`` (those in force), place the latest again.

        The trajectory placed last keeps its start if it had one (a stamp: a time of the new
        session), else it starts at ``now_ns`` (a zero stamp: on receipt, so again now): what
        the node was told to do stays, what is stamped with the old time goes.
        """
        trajectory, start = self.latest
        self.hold(targets)
        self.place(trajectory, start, now_ns)

    def at(self, t_ns: int) -> NDArray[np.float64]:
        """The targets in force at ``t_ns`` (ns of the clock), rad, shape (3,) (a new array)."""
        piece = self._pieces[bisect.bisect_right(self._starts, t_ns) - 1]
        return sample(*piece, t_ns)
