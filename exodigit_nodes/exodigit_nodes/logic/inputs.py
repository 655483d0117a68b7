"""Checks on incoming messages, as plain functions of their fields, and a rejection tally.

Every subscription of every node passes its message through one of these before using it. A
message that fails is dropped; the node keeps its last valid input and counts the reason.
"""

from __future__ import annotations

import math
from collections import Counter
from collections.abc import Sequence

import numpy as np
from numpy.typing import NDArray

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


def finite_values(data: Sequence[float], what: str, names: str) -> NDArray[np.float64]:
    """The values of a vector message as an array: as many as ``names`` lists, all finite.

    The checks every vector topic shares (pressures, efforts, targets, valve openings).

    Parameters
    ----------
    data : sequence of float
        The ``data`` field of a Float64MultiArray.
    what : str
        Name of the topic, for the reason.
    names : str
        The values in order, comma-separated (``'MCP, PIP, DIP'``): their count is the length.

    Raises
    ------
    InvalidInputError
        A wrong length or a non-finite value.
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
    return values


def joint_vector(data: Sequence[float], what: str, bound: float = math.inf) -> NDArray[np.float64]:
    """Three finite values (MCP, PIP, DIP) as an array, or :class:`InvalidInputError`.

    Parameters
    ----------
    data : sequence of float
        The ``data`` field of a Float64MultiArray.
    what : str
        Name of the topic, for the reason.
    bound : float
        Largest magnitude accepted (in the topic's unit).
    """
    values = finite_values(data, what, JOINTS)
    if np.abs(values).max() > bound:
        raise InvalidInputError(
            'out of range', f'{what} value beyond ±{bound:g}: {values.tolist()}'
        )
    return values


def valve_openings(data: Sequence[float], what: str) -> NDArray[np.float64]:
    """Six finite openings in [0, 1] (docs/spec/ros.md, "Valves"), or :class:`InvalidInputError`.

    The order of a ``valve_command``: the inlet valves of MCP, PIP, DIP, then their outlet valves
    (:data:`OPENINGS`). An opening outside [0, 1] is refused, not clipped: no valve opens
    beyond fully or less than closed, so such a command is a controller's bug.

    Parameters
    ----------
    data : sequence of float
        The ``data`` field of a Float64MultiArray.
    what : str
        Name of the topic, for the reason.
    """
    values = finite_values(data, what, OPENINGS)
    if ((values < 0.0) | (values > 1.0)).any():
        raise InvalidInputError(
            'out of range', f'{what} opening outside [0, 1]: {values.tolist()}'
        )
    return values


def joint_order(names: Sequence[str]) -> tuple[int, int, int]:
    """Index of MCP, PIP and DIP in ``names`` (each named ``<any prefix>mcp`` etc.)."""
    if len(names) != 3:
        raise InvalidInputError(
            'joint names', f'joint_states needs 3 joint names, got {len(names)}'
        )
    order = []
    for joint in JOINT_NAMES:
        found = [i for i, name in enumerate(names) if name.endswith(joint)]
        if len(found) != 1:
            raise InvalidInputError(
                'joint names',
                f'joint_states names {list(names)} must end in mcp, pip and dip once each',
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
    names, position = message.name, message.position
    velocity, effort = message.velocity, message.effort
    order = joint_order(names)
    if len(position) != 3:
        raise InvalidInputError(
            'lengths', f'joint_states has 3 names but {len(position)} positions'
        )
    for field, values in (('velocity', velocity), ('effort', effort)):
        if len(values) not in (0, 3):
            raise InvalidInputError(
                'lengths', f'joint_states has 3 names but {len(values)} {field} values'
            )
    return joint_vector([position[i] for i in order], 'joint_states position', MAX_ANGLE)


def stamp_seconds(stamp) -> float:
    """A builtin_interfaces/Time as seconds (any sec, including negative ones rclpy refuses)."""
    return stamp.sec + stamp.nanosec * 1e-9


def sent_seconds(info: dict) -> float:
    """When a received message was sent: its DDS source timestamp (rclpy message info), s."""
    return info['source_timestamp'] * 1e-9


def stamp_age(stamp_seconds: float, now: float, max_age: float, what: str) -> None:
    """Refuse a stamp farther than ``max_age`` s from ``now`` (zero, stale or future stamps)."""
    age = now - stamp_seconds
    if not math.isfinite(age) or abs(age) > max_age:
        when = f'{age:.3g} s ago' if age > 0 else f'{-age:.3g} s in the future'
        raise InvalidInputError(
            'stale', f'{what} stamped {when}, beyond max_sample_age {max_age:g} s'
        )


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
