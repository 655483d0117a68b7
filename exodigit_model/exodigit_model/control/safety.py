"""Safety limiter of the ``pressure_command`` node (docs/spec/ros.md, "Safety behaviour").

Whatever a controller asks, what is sent stays in [0, max_pressure], changes by at most
max_pressure_rate·dt per step, and ramps down toward zero while a joint is outside its range of
motion or a contact force exceeds max_contact_force. When the glove is back inside, the command
stays capped at what it was then (the pressure that brought it back), until the controller asks
for less: the glove settles at the edge of the range instead of pushing through it again.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from ..params import JOINT_NAMES


@dataclass(frozen=True)
class SafetyLimits:
    """Limits on the command; the defaults are the ``pressure_command`` node's.

    Attributes
    ----------
    max_pressure : float
        Highest pressure ever sent, Pa.
    max_pressure_rate : float
        Fastest change of any chamber's command, Pa/s.
    joint_lower, joint_upper : tuple of float
        Range of motion per joint (MCP, PIP, DIP), rad.
    max_contact_force : float
        Largest |contact force| tolerated, N.
    """

    max_pressure: float = 60e3
    max_pressure_rate: float = 100e3
    joint_lower: tuple[float, float, float] = (-0.1, -0.1, -0.1)
    joint_upper: tuple[float, float, float] = (1.57, 1.75, 1.4)
    # 10 N: the vented glove strapped on the stroke_severe preset's flexed finger already
    # carries 6 N at a contact; a lower default would leave that patient no way to move.
    max_contact_force: float = 10.0

    def __post_init__(self) -> None:
        """Refuse limits that cannot hold, naming them."""
        for name in ('max_pressure', 'max_pressure_rate', 'max_contact_force'):
            value = getattr(self, name)
            if not (math.isfinite(value) and value > 0.0):
                raise ValueError(f'{name} must be finite and > 0, got {value!r}')
        for joint, low, high in zip(JOINT_NAMES, self.joint_lower, self.joint_upper, strict=True):
            if not low < high:
                raise ValueError(
                    'joint_lower_limits must be below joint_upper_limits, '
                    f'{joint}: {low} >= {high}'
                )


@dataclass(frozen=True)
class Limited:
    """A limited command and why it differs from what was asked.

    Attributes
    ----------
    pressure : ndarray, shape (3,)
        What to send, Pa.
    reasons : dict of str to str
        Per limit that acted (``non-finite``, ``back-off``, ``ceiling``, ``pressure``,
        ``rate``), why;
        empty when the command went through untouched.
    """

    pressure: NDArray[np.float64]
    reasons: dict[str, str]


class SafetyLimiter:
    """Applies :class:`SafetyLimits` step by step, remembering the last command sent.

    Parameters
    ----------
    limits : SafetyLimits
        The limits.
    """

    def __init__(self, limits: SafetyLimits) -> None:
        self.limits = limits
        self.last = np.zeros(3)
        self.backing_off = False
        self.ceiling = np.full(3, np.inf)

    def violations(
        self, angles: NDArray[np.float64] | None, forces: NDArray[np.float64] | None
    ) -> list[str]:
        """Why the glove must back off now (empty if it need not)."""
        limits = self.limits
        found = []
        if angles is not None:
            for joint, q, low, high in zip(
                JOINT_NAMES, angles, limits.joint_lower, limits.joint_upper, strict=True
            ):
                if not low <= q <= high:
                    found.append(f'{joint} at {q:.3f} rad outside [{low:g}, {high:g}]')
        if forces is not None:
            for joint, f in zip(JOINT_NAMES, forces, strict=True):
                if abs(f) > limits.max_contact_force:
                    found.append(
                        f'{joint} contact force {f:.3g} N beyond {limits.max_contact_force:g}'
                    )
        return found

    def apply(
        self,
        desired: NDArray[np.float64],
        dt: float,
        angles: NDArray[np.float64] | None = None,
        forces: NDArray[np.float64] | None = None,
    ) -> Limited:
        """The command to send for ``desired`` (Pa) after ``dt`` s at the given feedback."""
        limits = self.limits
        reasons = {}
        if not np.isfinite(desired).all():
            reasons['non-finite'] = f'controller asked for {desired.tolist()}; sending toward 0'
            desired = np.zeros(3)
        violations = self.violations(angles, forces)
        if violations:
            target = np.zeros(3)
            reasons['back-off'] = 'backing off: ' + '; '.join(violations)
        else:
            if self.backing_off:  # just back inside: cap at the pressure that got us here
                self.ceiling = self.last.copy()
            if (desired <= self.ceiling).all():
                self.ceiling = np.full(3, np.inf)
            target = np.minimum(desired, self.ceiling)
            if np.isfinite(self.ceiling).any():
                reasons['ceiling'] = f'capped at {self.ceiling.tolist()} Pa after a back-off'
        self.backing_off = bool(violations)
        bounded = np.clip(target, 0.0, limits.max_pressure)
        if not np.array_equal(bounded, target):
            reasons['pressure'] = f'pressure limited to [0, {limits.max_pressure:g}] Pa'
        step = limits.max_pressure_rate * max(dt, 0.0)
        ramped = np.clip(bounded, self.last - step, self.last + step)
        if not np.array_equal(ramped, bounded):
            reasons['rate'] = f'rate limited to {limits.max_pressure_rate:g} Pa/s'
        # The range wins over the rate when max_pressure was just lowered below the last command.
        sent = np.clip(ramped, 0.0, limits.max_pressure)
        self.last = sent
        return Limited(sent.copy(), reasons)
