"""Checks on incoming messages, as plain functions of their fields, and a rejection tally.

A message that fails a check is dropped; the node keeps its last valid input and counts the
reason (docs/spec/ros.md, "Safety behaviour").
"""

from __future__ import annotations

import math
from collections import Counter
from collections.abc import Sequence

import numpy as np
from exodigit_model.control import Trajectory, TrajectoryError
from exodigit_model.stepping.settings import NANOSECONDS
from numpy.typing import ArrayLike, NDArray

from exodigit_model import JOINT_NAMES


class InvalidInputError(ValueError):
    """An input message was dropped; ``kind`` is a short key for counting, the text says why."""

    def __init__(self, kind: str, detail: str) -> None:
        super().__init__(detail)
        self.kind = kind


JOINTS = 'MCP, PIP, DIP'
"""The values of a joint vector, in order."""
OPENINGS = 'inlet MCP, inlet PIP, inlet DIP, outlet MCP, outlet PIP, outlet DIP'
"""The values of a valve command, in order (docs/spec/model.md §14)."""
MAX_PRESSURE_READING = 10e6
"""Largest |chamber pressure| accepted as a measurement, Pa."""
MAX_ANGLE = math.pi
"""Largest |joint angle| a measurement may report, rad; beyond it the message is not physical."""


def _finite_values(
    data: Sequence[float], what: str, names: str, low: ArrayLike, high: ArrayLike, outside: str
) -> NDArray[np.float64]:
    """``data`` as finite values in [``low``, ``high``], one per name of ``names`` (a, b, c).

    ``what`` names the topic and ``outside`` the range broken, for the reason; the ends may be
    arrays (one per value).
    """
    size = len(names.split(','))
    if len(data) != size:
        raise InvalidInputError(
            'wrong length', f'{what} needs {size} values ({names}), got {len(data)}'
        )
    values = np.array(data, dtype=float)
    if not np.isfinite(values).all():
        raise InvalidInputError(
            'non-finite', f'{what} holds a non-finite value: {values.tolist()}'
        )
    if ((values < low) | (values > high)).any():
        raise InvalidInputError('out of range', f'{what} {outside}: {values.tolist()}')
    return values


def joint_vector(data: Sequence[float], what: str, bound: float = math.inf) -> NDArray[np.float64]:
    """Three finite values (MCP, PIP, DIP) of topic ``what``, none beyond ±``bound`` (its unit)."""
    return _finite_values(data, what, JOINTS, -bound, bound, f'value beyond ±{bound:g}')


def valve_openings(data: Sequence[float], what: str) -> NDArray[np.float64]:
    """Six finite openings in [0, 1] (:data:`OPENINGS`) of topic ``what``.

    An opening outside [0, 1] is a controller's bug: refused, not clipped.
    """
    return _finite_values(data, what, OPENINGS, 0.0, 1.0, 'opening outside [0, 1]')


def joint_order(names: Sequence[str], what: str = 'joint_states') -> tuple[int, int, int]:
    """Index of MCP, PIP and DIP in ``names`` (each named ``<any prefix>mcp`` etc.)."""
    if len(names) != 3:
        raise InvalidInputError('joint names', f'{what} needs 3 joint names, got {len(names)}')
    order = []
    for joint in JOINT_NAMES:
        found = [i for i, name in enumerate(names) if name.endswith(joint)]
        if len(found) != 1:
            raise InvalidInputError(
                'joint names',
                f'{what} names {list(names)} must end in mcp, pip and dip once each',
            )
        order.append(found[0])
    return order[0], order[1], order[2]


def joint_positions(message) -> NDArray[np.float64]:
    """Joint angles (rad, in MCP, PIP, DIP order) from a sensor_msgs/JointState.

    The message may list the joints in any order; velocity and effort may be empty (as
    sensor_msgs/JointState allows) but otherwise have one entry per name.

    Raises
    ------
    InvalidInputError
        Wrong names, mismatched lengths, non-finite or impossible (beyond ±π) positions.
    """
    order = joint_order(message.name)
    for field, values, sizes in (
        ('positions', message.position, (3,)),
        ('velocity values', message.velocity, (0, 3)),
        ('effort values', message.effort, (0, 3)),
    ):
        if len(values) not in sizes:
            raise InvalidInputError(
                'lengths', f'joint_states has 3 names but {len(values)} {field}'
            )
    return joint_vector([message.position[i] for i in order], 'joint_states position', MAX_ANGLE)


def joint_targets(message, lower, upper) -> tuple[Trajectory, None]:
    """A ``joint_targets`` message (rad) as what it is: a one-point trajectory from now (None).

    Raises
    ------
    InvalidInputError
        Not three finite angles, or outside ``lower`` .. ``upper`` (rad).
    """
    rule = f'outside the range of motion {list(lower)} .. {list(upper)} rad'
    targets = _finite_values(message.data, 'joint_targets', JOINTS, lower, upper, rule)
    return Trajectory.hold(targets), None


def joint_trajectory(message, lower, upper) -> tuple[Trajectory, int | None]:
    """A trajectory_msgs/JointTrajectory as a :class:`Trajectory` (MCP, PIP, DIP) and its start.

    The joints named as ``joint_states`` names them (``<any prefix>mcp`` ...), in any order;
    each point with three positions, optionally three velocities (every point or none), no
    accelerations or efforts (not interpolated here); the positions inside ``lower`` ..
    ``upper`` (rad). The start is the header stamp in ns, None for a zero stamp (on receipt).

    Raises
    ------
    InvalidInputError
        Naming the rule broken (the whole trajectory is refused).
    """
    what = 'joint_trajectory'
    order = joint_order(message.joint_names, what)
    points = message.points
    positions, velocities, times = [], [], []
    for k, point in enumerate(points):
        if len(point.positions) != 3 or len(point.velocities) not in (0, 3):
            raise InvalidInputError(
                'lengths',
                f'{what} point {k}: {len(point.positions)} positions and '
                f'{len(point.velocities)} velocities, must be 3 and 3 or none',
            )
        if len(point.accelerations) or len(point.effort):
            raise InvalidInputError(
                'unsupported',
                f'{what} point {k} has accelerations or efforts: only positions and '
                'velocities are followed',
            )
        positions.append([point.positions[i] for i in order])
        if len(point.velocities):
            velocities.append([point.velocities[i] for i in order])
        times.append(stamp_nanoseconds(point.time_from_start) / NANOSECONDS)
    if len(velocities) not in (0, len(points)):
        raise InvalidInputError('lengths', f'{what}: velocities for some points, not all')
    try:
        trajectory = Trajectory(times, positions, velocities or None)
        trajectory.check_range(lower, upper)
    except TrajectoryError as error:
        raise InvalidInputError(error.rule, f'{what} refused: {error}') from None
    start = stamp_nanoseconds(message.header.stamp)
    return trajectory, start or None


def stamp_nanoseconds(stamp) -> int:
    """A builtin_interfaces/Time or Duration as whole nanoseconds."""
    return stamp.sec * NANOSECONDS + stamp.nanosec


def stamp_seconds(stamp) -> float:
    """A builtin_interfaces/Time as seconds (any sec, including negative ones rclpy refuses)."""
    return stamp.sec + stamp.nanosec * 1e-9


def sent_seconds(info: dict) -> float:
    """When a received message was sent: its DDS source timestamp (rclpy message info), s."""
    return info['source_timestamp'] * 1e-9


def stamp_age(
    stamp: float, now: float, max_age: float, what: str, key: str = 'max_sample_age'
) -> None:
    """Refuse a stamp farther than ``max_age`` s (the parameter ``key``) from ``now``.

    Zero, stale and future stamps alike.
    """
    age = now - stamp
    if not math.isfinite(age) or abs(age) > max_age:
        when = f'{age:.3g} s ago' if age > 0 else f'{-age:.3g} s in the future'
        raise InvalidInputError('stale', f'{what} stamped {when}, beyond {key} {max_age:g} s')


class RejectionTally:
    """Counts of dropped messages per topic and reason, with the latest reason kept."""

    def __init__(self) -> None:
        self.counts: Counter[tuple[str, str]] = Counter()
        self.last_reason = ''

    def add(self, topic: str, error: InvalidInputError) -> None:
        """Count one dropped message on ``topic``."""
        self.counts[(topic, error.kind)] += 1
        self.last_reason = str(error)

    @property
    def total(self) -> int:
        """Messages dropped so far."""
        return sum(self.counts.values())

    def summary(self) -> dict[str, str]:
        """Counts as diagnostic key/values (``rejected <topic>: <reason>``)."""
        values = {f'rejected {topic}: {kind}': str(n) for (topic, kind), n in self.counts.items()}
        if self.last_reason:
            values['last rejection'] = self.last_reason
        return values
