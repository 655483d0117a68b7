"""Session protocols: how long a trial session lasts, at what rate, and the joint targets in it.

A protocol is a duration (s), a rate f (Hz; the step Δt = 1/f) and a target posture
q*(t) = (MCP, PIP, DIP), rad, flexion positive (docs/spec/model.md §1), for every time t >= 0 s
from the start of the session. The session has ``duration · rate_hz`` steps; step k ends at
t_k = k·Δt (exactly the simulation's time grid,
:func:`~exodigit_model.stepping.settings.step_time_ns`), and a trial compares the finger there
with q*(t_k). Four kinds, listed by name in :data:`PROTOCOLS` (docs/trials.md, "Protocols",
has their sources):

- ``cpm``, :class:`ContinuousPassiveMotion`: a smooth flex-extend cycle between two postures;
- ``staircase``, :class:`Staircase`: stairs of flexion up to a posture and back, each held;
- ``grasp``, :class:`GraspRelease`: close to a grasp posture, hold, open, rest, repeated;
- ``trajectory``, :class:`TrajectoryProtocol`: timed points, interpolated as ``pressure_command``
  interpolates a ``joint_trajectory`` (:class:`~exodigit_model.control.Trajectory`).

Every protocol is also a trajectory of one point a step (:meth:`SessionProtocol.trajectory`):
what the ``position`` mode tracks in process and what the testing kit sends a ROS node.

>>> from exodigit_model.trials import make_protocol
>>> protocol = make_protocol('cpm', duration=20.0)
>>> protocol.steps, protocol.targets(protocol.times()).shape
(2000, (2000, 3))
"""

from __future__ import annotations

import math
from abc import ABC, abstractmethod
from collections.abc import Mapping
from dataclasses import MISSING, dataclass, field, fields
from types import MappingProxyType
from typing import ClassVar

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..checks import ParameterError, check_non_negative, check_positive, set_field
from ..control.cycles import flex_extend, rise
from ..control.trajectory import Trajectory
from ..physics.model import as_joint_vector
from ..stepping.settings import NANOSECONDS, step_time_ns

DEFAULT_DURATION = 60.0
"""Session length, s: the one-minute session of a trial (judgement)."""

DEFAULT_RATE = 100.0
"""Steps per second, Hz: the plant's default rate (docs/spec/model.md §13)."""

STRAIGHT = (0.0, 0.0, 0.0)
"""The straight finger, rad: the zero of every joint angle (docs/spec/model.md §1)."""

FUNCTIONAL_FLEXION = tuple(math.radians(angle) for angle in (61.0, 60.0, 39.0))
"""Functional flexion posture, rad: the mean flexion of MCP, PIP and DIP over 11 activities of
daily living, 61°, 60° and 39° (Hume et al. 1990, docs/trials.md, "References")."""

FUNCTIONAL_RANGE = (
    tuple(math.radians(angle) for angle in (19.0, 23.0, 10.0)),
    tuple(math.radians(angle) for angle in (71.0, 87.0, 64.0)),
)
"""Functional range of motion, rad, (lower ends, upper ends): 19-71° MCP, 23-87° PIP and 10-64°
DIP, the range 90 % of 20 activities of daily living need (Bain et al. 2015, docs/trials.md,
"References")."""

STAIR_DIGITS = 9
"""t/hold is rounded to this many decimals before it is floored, so a time within 1e-9 of a
hold of a stair's start (float rounding of k·Δt) belongs to that stair."""


def _posture(name: str, value: ArrayLike) -> tuple[float, float, float]:
    """``value`` as three finite angles (MCP, PIP, DIP), rad, or a ValueError naming ``name``."""
    return tuple(as_joint_vector(name, value).tolist())


@dataclass(frozen=True, kw_only=True)
class SessionProtocol(ABC):
    """What every protocol has: a duration and a rate; the kinds add the targets.

    Attributes
    ----------
    duration : float
        Length of the session, s (> 0); ``duration · rate_hz`` must be a whole number of steps.
    rate_hz : float
        Steps per second, Hz (> 0).
    """

    summary: ClassVar[str] = ''
    """One line for listings (:data:`PROTOCOLS`)."""

    duration: float = DEFAULT_DURATION
    rate_hz: float = DEFAULT_RATE

    def __post_init__(self) -> None:
        """Refuse a duration or rate that is not > 0, or that makes a fraction of a step."""
        duration = check_positive('duration', self.duration, 's')
        rate_hz = check_positive('rate_hz', self.rate_hz, 'Hz')
        steps = duration * rate_hz
        if round(steps) < 1 or not math.isclose(steps, round(steps), rel_tol=1e-9):
            raise ParameterError(
                f'duration = {duration!r} s at rate_hz = {rate_hz!r} Hz is {steps:g} steps: '
                'must be a whole number of steps, at least 1'
            )
        set_field(self, 'duration', duration)
        set_field(self, 'rate_hz', rate_hz)

    @property
    def steps(self) -> int:
        """Number of steps of the session, ``duration · rate_hz``."""
        return round(self.duration * self.rate_hz)

    def times(self) -> NDArray[np.float64]:
        """t_k, s, for k = 1 … :attr:`steps`: when each step of the session ends."""
        return (
            np.array([step_time_ns(k, self.rate_hz) for k in range(1, self.steps + 1)])
            / NANOSECONDS
        )

    def targets(self, t: ArrayLike) -> NDArray[np.float64]:
        """q*(t), rad, shape ``t.shape + (3,)`` (MCP, PIP, DIP), for times t >= 0 s.

        Raises
        ------
        ValueError
            If a time is not a finite number >= 0.
        """
        try:
            times = np.asarray(t, dtype=float)
        except (TypeError, ValueError):
            times = None
        if times is None or not np.all(np.isfinite(times)) or np.any(times < 0.0):
            raise ValueError(f't = {t!r}: must be finite times >= 0 s')
        return self._targets(times)

    def trajectory(self) -> Trajectory:
        """The session's targets as a trajectory: q*(t_k) at t_k, one point a step (k >= 1).

        Sampled at t_k it gives q*(t_k) exactly; the ``position`` mode tracks it, in process
        and as a ROS node (the testing kit sends it on ``joint_trajectory``).
        """
        times = self.times()
        return Trajectory(times, self.targets(times))

    @abstractmethod
    def _targets(self, t: NDArray[np.float64]) -> NDArray[np.float64]:
        """q*(t) for checked times ``t``, shape ``t.shape + (3,)``."""


@dataclass(frozen=True, kw_only=True)
class ContinuousPassiveMotion(SessionProtocol):
    """Continuous passive motion: the smooth flex-extend cycle of :func:`flex_extend`, repeated.

    Attributes
    ----------
    low, high : tuple of float
        The extended and the flexed posture, MCP, PIP, DIP, rad. Default: the ends of the
        functional range of motion, :data:`FUNCTIONAL_RANGE`.
    period : float
        Duration of one flex-extend cycle, s (> 0). Default 10 s (judgement: slow, as passive
        motion is; the fastest joint, the PIP, then moves at most π·64°/10 s ≈ 0.35 rad/s,
        below the spasticity thresholds of the mild and moderate presets, docs/patients.md).
    """

    summary: ClassVar[str] = 'continuous passive motion: a smooth flex-extend cycle, repeated'

    low: tuple[float, float, float] = FUNCTIONAL_RANGE[0]
    high: tuple[float, float, float] = FUNCTIONAL_RANGE[1]
    period: float = 10.0

    def __post_init__(self) -> None:
        """Refuse postures that are not three finite angles or a period that is not > 0."""
        super().__post_init__()
        set_field(self, 'low', _posture('low', self.low))
        set_field(self, 'high', _posture('high', self.high))
        set_field(self, 'period', check_positive('period', self.period, 's'))

    def _targets(self, t: NDArray[np.float64]) -> NDArray[np.float64]:
        return flex_extend(t, np.array(self.low), np.array(self.high), self.period)


@dataclass(frozen=True, kw_only=True)
class Staircase(SessionProtocol):
    """Stairs of flexion: 0, 1/n, …, 1, (n − 1)/n, …, 1/n of ``peak``, each held, repeated.

    Stair i (from 0) is held for t in [i·hold, (i + 1)·hold); the levels go up from the straight
    finger in ``stairs`` equal steps to ``peak`` and back down, a cycle of 2·stairs stairs. The
    target jumps between stairs (it is not continuous).

    Attributes
    ----------
    peak : tuple of float
        Top of the staircase, MCP, PIP, DIP, rad. Default :data:`FUNCTIONAL_FLEXION`.
    stairs : int
        n, the steps up to the peak (>= 1). Default 5, as the paper's staircase of 10 kPa
        steps up to 50 kPa (the ``pressure_command`` node's staircase).
    hold : float
        Time on each stair, s (> 0). Default 2 s, the node's ``step_duration`` (judgement).
    """

    summary: ClassVar[str] = 'stairs of flexion up to a posture and back, each held for a time'

    peak: tuple[float, float, float] = FUNCTIONAL_FLEXION
    stairs: int = 5
    hold: float = 2.0

    def __post_init__(self) -> None:
        """Refuse a peak that is not three finite angles, stairs < 1 or a hold that is not > 0."""
        super().__post_init__()
        set_field(self, 'peak', _posture('peak', self.peak))
        if isinstance(self.stairs, bool) or not isinstance(self.stairs, int) or self.stairs < 1:
            raise ParameterError(f'stairs = {self.stairs!r}: must be a whole number >= 1')
        set_field(self, 'hold', check_positive('hold', self.hold, 's'))

    def _targets(self, t: NDArray[np.float64]) -> NDArray[np.float64]:
        stair = np.floor(np.round(t / self.hold, STAIR_DIGITS)) % (2 * self.stairs)
        level = (self.stairs - np.abs(self.stairs - stair)) / self.stairs
        return level[..., np.newaxis] * np.array(self.peak)


@dataclass(frozen=True, kw_only=True)
class GraspRelease(SessionProtocol):
    """Grasp and release: close to a grasp posture, hold, open to rest, rest; repeated.

    One cycle lasts close_time + hold_time + open_time + rest_time. The closing and the opening
    are the smooth rise of :func:`rise` (zero speed at both ends), so the target and its rate
    are continuous.

    Attributes
    ----------
    grasp : tuple of float
        The grasp posture, MCP, PIP, DIP, rad. Default :data:`FUNCTIONAL_FLEXION`.
    rest : tuple of float
        The open posture, rad. Default :data:`STRAIGHT` (judgement).
    close_time, open_time : float
        Time to close and to open, s (> 0). Default 2 s each (judgement).
    hold_time, rest_time : float
        Time held closed and held open, s (>= 0). Default 3 s each (judgement).
    """

    summary: ClassVar[str] = 'close to a grasp posture, hold, open, rest; repeated'

    grasp: tuple[float, float, float] = FUNCTIONAL_FLEXION
    rest: tuple[float, float, float] = STRAIGHT
    close_time: float = 2.0
    hold_time: float = 3.0
    open_time: float = 2.0
    rest_time: float = 3.0

    def __post_init__(self) -> None:
        """Refuse postures that are not three finite angles and times out of their range."""
        super().__post_init__()
        set_field(self, 'grasp', _posture('grasp', self.grasp))
        set_field(self, 'rest', _posture('rest', self.rest))
        for name in ('close_time', 'open_time'):
            set_field(self, name, check_positive(name, getattr(self, name), 's'))
        for name in ('hold_time', 'rest_time'):
            set_field(self, name, check_non_negative(name, getattr(self, name), 's'))

    @property
    def cycle(self) -> float:
        """Duration of one grasp-and-release, s."""
        return self.close_time + self.hold_time + self.open_time + self.rest_time

    def _targets(self, t: NDArray[np.float64]) -> NDArray[np.float64]:
        s = np.mod(t, self.cycle)
        closing = np.clip(s, 0.0, self.close_time)
        opening = np.clip(s - self.close_time - self.hold_time, 0.0, self.open_time)
        grip = rise(closing, 2.0 * self.close_time) - rise(opening, 2.0 * self.open_time)
        rest, grasp = np.array(self.rest), np.array(self.grasp)
        return rest + (grasp - rest) * grip[..., np.newaxis]


@dataclass(frozen=True, kw_only=True)
class TrajectoryProtocol(SessionProtocol):
    """Timed joint targets: a :class:`~exodigit_model.control.Trajectory` from the session's start.

    Between points linear, or cubic where both points have velocities; before the first point
    its posture, after the last one the last (as ``pressure_command`` samples a
    ``joint_trajectory``: docs/spec/ros.md, "Trajectories").

    Attributes
    ----------
    point_times : tuple of float
        Time of each point from the session's start, s (increasing, from 0).
    positions : tuple of tuple of float
        Joint angles of each point, MCP, PIP, DIP, rad.
    velocities : tuple of tuple of float
        Joint speeds of each point, rad/s; empty: positions only.
    """

    summary: ClassVar[str] = 'timed points, interpolated as pressure_command takes a trajectory'

    point_times: tuple[float, ...]
    positions: tuple[tuple[float, float, float], ...]
    velocities: tuple[tuple[float, float, float], ...] = ()
    _path: Trajectory = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        """Refuse points that do not make a trajectory (the field and the rule named)."""
        super().__post_init__()
        try:
            path = Trajectory(self.point_times, self.positions, self.velocities or None)
        except ValueError as error:
            raise ParameterError(
                f'protocol trajectory (point_times, positions): {error}'
            ) from None
        set_field(self, 'point_times', tuple(path.times.tolist()))
        set_field(self, 'positions', tuple(map(tuple, path.positions.tolist())))
        rows = () if path.velocities is None else path.velocities.tolist()
        set_field(self, 'velocities', tuple(map(tuple, rows)))
        set_field(self, '_path', path)

    def _targets(self, t: NDArray[np.float64]) -> NDArray[np.float64]:
        return self._path.at(t)


PROTOCOLS: Mapping[str, type[SessionProtocol]] = MappingProxyType(
    {
        'cpm': ContinuousPassiveMotion,
        'staircase': Staircase,
        'grasp': GraspRelease,
        'trajectory': TrajectoryProtocol,
    }
)
"""The protocols by name; each class's ``summary`` says what it does."""


def make_protocol(name: str, **parameters: object) -> SessionProtocol:
    """The protocol ``name`` of :data:`PROTOCOLS` with ``parameters`` over its defaults.

    Raises
    ------
    ValueError
        For an unknown name (the message lists the known ones), an unknown parameter, or a
        value that breaks its rule (naming the field).
    """
    if name not in PROTOCOLS:
        raise ValueError(f'protocol {name!r}: unknown (known: {", ".join(PROTOCOLS)})')
    kind = PROTOCOLS[name]
    known = [item.name for item in fields(kind) if item.init]
    unknown = sorted(set(parameters) - set(known))
    if unknown:
        raise ValueError(
            f'protocol {name!r}: unknown parameter {unknown[0]!r} (known: {", ".join(known)})'
        )
    required = [item.name for item in fields(kind) if item.init and item.default is MISSING]
    missing = [key for key in required if key not in parameters]
    if missing:
        raise ValueError(f'protocol {name!r}: parameter {missing[0]!r} is required')
    return kind(**parameters)
