"""Safety limiter of the ``pressure_command`` node (docs/spec/ros.md, "Safety behaviour").

Whatever a controller asks, what is sent stays in [0, max_pressure], changes by at most
max_pressure_rate·dt per step, and ramps down toward zero while a joint is outside its range of
motion or a contact force exceeds max_contact_force. When the glove is back inside, the command
stays capped at what it was then (the pressure that brought it back), until the controller asks
for less: the glove settles at the edge of the range instead of pushing through it again.

One limiter limits one glove (arrays of shape (3,)), as the node does, or a batch of gloves
(N, 3) with the same arithmetic, every row on its own: its last command, its back-off and its
cap (:mod:`.shapes`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from ..physics.params import JOINT_NAMES
from .shapes import any_joint, check_shape, every_joint, glove_shape

LIMIT_KINDS = ('non-finite', 'back-off', 'ceiling', 'pressure', 'rate')
"""The limits, in the order the limiter applies them: the columns of :attr:`Limited.acted`.

``non-finite``: the controller asked for NaN or ±inf, so the glove is sent toward zero;
``back-off``: a joint is outside its range of motion or a contact force above the limit, so
toward zero; ``ceiling``: capped after a back-off; ``pressure``: the request was outside
[0, max_pressure]; ``rate``: the change was faster than max_pressure_rate."""


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


LIMIT_PARAMETERS = {
    'max_pressure': 'max_pressure',
    'max_pressure_rate': 'max_pressure_rate',
    'joint_lower_limits': 'joint_lower',
    'joint_upper_limits': 'joint_upper',
    'max_contact_force': 'max_contact_force',
}
"""The ``pressure_command`` node's safety parameters and the :class:`SafetyLimits` fields they
set (a trial's built-in modes take the same names)."""


@dataclass(frozen=True)
class Limited:
    """A limited command and why it differs from what was asked.

    Attributes
    ----------
    pressure : ndarray, shape (3,) or (N, 3)
        What to send, Pa.
    reasons : dict of str to str
        Per limit that acted (keys of :data:`LIMIT_KINDS`, in that order), why; empty when the
        command went through untouched. For one glove the text names the values (the joints
        outside their range, the cap, ...); for a batch it says on how many gloves the limit
        acted.
    acted : ndarray of bool, shape (5,) or (N, 5)
        Whether each limit of :data:`LIMIT_KINDS` acted, per glove.
    """

    pressure: NDArray[np.float64]
    reasons: dict[str, str]
    acted: NDArray[np.bool_]


class SafetyLimiter:
    """Applies :class:`SafetyLimits` step by step, remembering the last command sent.

    Parameters
    ----------
    limits : SafetyLimits
        The limits (replaceable: ``limiter.limits = ...`` applies from the next step).
    count : int, optional
        Gloves limited together, one row each; None (the default): one glove, arrays (3,).
    """

    def __init__(self, limits: SafetyLimits, *, count: int | None = None) -> None:
        self.limits = limits
        self.reset(count)

    def reset(self, count: int | None = None) -> None:
        """Start afresh for one glove (``count`` None) or ``count``: nothing sent, no back-off."""
        self.shape = glove_shape(count)
        """(3,) or (count, 3): the shape of every command and feedback array."""
        self.last = np.zeros(self.shape)
        """The last command sent, Pa."""
        self.backing_off = np.zeros(self.shape[:-1], bool)
        """Per glove: whether the last command backed off."""
        self.ceiling = np.full(self.shape, np.inf)
        """Per glove and chamber: the cap after a back-off, Pa (inf: none)."""

    def apply(
        self,
        desired: NDArray[np.float64],
        dt: float,
        angles: NDArray[np.float64] | None = None,
        forces: NDArray[np.float64] | None = None,
    ) -> Limited:
        """The command to send for ``desired`` (Pa) after ``dt`` s at the given feedback.

        Parameters
        ----------
        desired : ndarray, shape (3,) or the limiter's
            What the controller asks, Pa; shape (3,) asks the same of every glove.
        dt : float
            Time since the previous command, s (the same for every glove).
        angles : ndarray, optional
            Measured joint angles, rad, of the limiter's shape; None: none (no range check).
        forces : ndarray, optional
            Contact forces, N, of the limiter's shape; None: none (no force check).

        Raises
        ------
        ValueError
            If an array does not have the limiter's shape.
        """
        limits, shape = self.limits, self.shape
        check_shape('angles', angles, shape)
        check_shape('forces', forces, shape)
        requested = np.asarray(desired)
        if requested.shape != shape:
            if requested.shape != (3,):
                check_shape('desired', requested, shape)
            requested = np.broadcast_to(requested, shape)
        non_finite = ~every_joint(np.isfinite(requested))
        desired = np.where(non_finite[..., None], 0.0, requested)
        outside = np.zeros(shape, bool)
        if angles is not None:  # written as a range test so that NaN counts as outside
            outside = ~((angles >= limits.joint_lower) & (angles <= limits.joint_upper))
        above = np.zeros(shape, bool)
        if forces is not None:
            above = np.abs(forces) > limits.max_contact_force
        violated = any_joint(outside | above)
        inside = ~violated
        # just back inside: cap at the pressure that got us here, until the controller asks
        # for no more than the cap
        ceiling = np.where((inside & self.backing_off)[..., None], self.last, self.ceiling)
        released = inside & every_joint(desired <= ceiling)
        ceiling = np.where(released[..., None], np.inf, ceiling)
        capped = inside & any_joint(np.isfinite(ceiling))
        target = np.where(violated[..., None], 0.0, np.minimum(desired, ceiling))
        self.ceiling, self.backing_off = ceiling, violated
        bounded = np.clip(target, 0.0, limits.max_pressure)
        step = limits.max_pressure_rate * max(dt, 0.0)
        ramped = np.clip(bounded, self.last - step, self.last + step)
        # The range wins over the rate when max_pressure was just lowered below the last command.
        sent = np.clip(ramped, 0.0, limits.max_pressure)
        self.last = sent
        acted = np.empty((*shape[:-1], len(LIMIT_KINDS)), bool)
        for column, mask in enumerate(
            (
                non_finite,
                violated,
                capped,
                any_joint(bounded != target),
                any_joint(ramped != bounded),
            )
        ):
            acted[..., column] = mask
        if acted.ndim == 1:
            reasons = _glove_reasons(
                limits, acted, requested, outside, above, angles, forces, ceiling
            )
        else:
            reasons = _batch_reasons(limits, acted)
        return Limited(sent.copy(), reasons, acted)


def _glove_reasons(
    limits: SafetyLimits,
    acted: NDArray[np.bool_],
    requested: NDArray[np.float64],
    outside: NDArray[np.bool_],
    above: NDArray[np.bool_],
    angles: NDArray[np.float64] | None,
    forces: NDArray[np.float64] | None,
    ceiling: NDArray[np.float64],
) -> dict[str, str]:
    """Why each limit acted on one glove, naming the values (the node logs these)."""
    reasons = {}
    non_finite, backing_off, capped, pressure, rate = acted.tolist()
    if non_finite:
        reasons['non-finite'] = f'controller asked for {requested.tolist()}; sending toward 0'
    if backing_off:
        found = [
            f'{joint} at {angles[k]:.3f} rad outside '
            f'[{limits.joint_lower[k]:g}, {limits.joint_upper[k]:g}]'
            for k, joint in enumerate(JOINT_NAMES)
            if outside[k]
        ] + [
            f'{joint} contact force {forces[k]:.3g} N beyond {limits.max_contact_force:g}'
            for k, joint in enumerate(JOINT_NAMES)
            if above[k]
        ]
        reasons['back-off'] = 'backing off: ' + '; '.join(found)
    if capped:
        reasons['ceiling'] = f'capped at {ceiling.tolist()} Pa after a back-off'
    if pressure:
        reasons['pressure'] = _pressure_reason(limits)
    if rate:
        reasons['rate'] = _rate_reason(limits)
    return reasons


def _batch_reasons(limits: SafetyLimits, acted: NDArray[np.bool_]) -> dict[str, str]:
    """Why each limit acted on a batch: what it does and on how many gloves."""
    what = {
        'non-finite': 'controller asked for non-finite pressures; sending toward 0',
        'back-off': 'backing off: a joint outside its range of motion or a contact force '
        f'beyond {limits.max_contact_force:g} N',
        'ceiling': 'capped after a back-off',
        'pressure': _pressure_reason(limits),
        'rate': _rate_reason(limits),
    }
    gloves = acted.shape[0]
    return {
        kind: f'{what[kind]} on {count} of {gloves} gloves'
        for kind, count in zip(LIMIT_KINDS, np.count_nonzero(acted, axis=0).tolist(), strict=True)
        if count
    }


def _pressure_reason(limits: SafetyLimits) -> str:
    return f'pressure limited to [0, {limits.max_pressure:g}] Pa'


def _rate_reason(limits: SafetyLimits) -> str:
    return f'rate limited to {limits.max_pressure_rate:g} Pa/s'
