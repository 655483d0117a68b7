r"""The patient's finger: the joint torque τ_H of MODEL.md §11, eqs (11.1)-(11.3).

Per joint, the torque the finger needs from outside to hold angle q while moving at q̇ is

.. math::

    \tau_H = k\,(q - q_r) + e(q) + c\,\dot q + s(\dot q) - u \qquad (11.1)

with the range-of-motion stiffening (zero at q_r, rising steeply towards q_min and q_max)

.. math::

    e(q) = a\,[e^{\beta(q - q_{max})} - e^{\beta(q_r - q_{max})}]
         - a\,[e^{\beta(q_{min} - q)} - e^{\beta(q_{min} - q_r)}] \qquad (11.2)

and the spasticity, smoothed so that it is exactly zero at q̇ = 0 and differentiable everywhere

.. math::

    s(v) = g_e\,[S(v) - S(0)] - g_f\,[S(-v) - S(0)], \qquad
    S(v) = w \ln(1 + e^{(v - v_t)/w}) \qquad (11.3)

(g_f: flexors resisting extension, g_e: extensors resisting flexion, w = ``SPASTICITY_WIDTH``).
u is the patient's voluntary effort (u > 0 helps flexion). A static solve has q̇ = 0; a stepped
solve uses q̇ = (q − q_prev)/Δt inside the equation (implicit, stable at any step), whose
∂τ_H/∂q = k + e'(q) + (c + s'(q̇))/Δt the Newton iteration needs. With every new parameter at its
default, τ_H = k·q exactly: eq 32 of the paper.

Everything works on per-joint floats or 1-D arrays (:mod:`._backend`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from ._backend import ScalarOps
from .params import FingerJoint

SPASTICITY_WIDTH = 0.01
"""w of eq (11.3): the velocity over which the spastic resistance switches on, rad/s."""


@dataclass(frozen=True)
class JointLaw:
    """The constants of (11.1)-(11.3) for one joint (names as in the parameter file)."""

    stiffness: float
    rest_angle: float
    rom_torque: float
    rom_sharpness: float
    rom_min: float
    rom_max: float
    damping: float
    spasticity: float
    extensor_spasticity: float
    spasticity_threshold: float

    def __post_init__(self) -> None:
        """Precompute what does not depend on the state (the offsets that zero e and s at rest)."""
        beta = self.rom_sharpness
        derived = {
            'stiffening': self.rom_torque > 0.0,
            'viscous': self.damping > 0.0 or self.spasticity > 0.0 or self.extensor_spasticity > 0,
            '_upper_at_rest': math.exp(beta * (self.rest_angle - self.rom_max)),
            '_lower_at_rest': math.exp(beta * (self.rom_min - self.rest_angle)),
            '_spastic_at_zero': SPASTICITY_WIDTH
            * ScalarOps.softplus_and_sigmoid(-self.spasticity_threshold / SPASTICITY_WIDTH)[0],
        }
        for name, value in derived.items():
            object.__setattr__(self, name, value)

    @classmethod
    def of(cls, joint: FingerJoint) -> JointLaw:
        """The law of a validated finger joint."""
        return cls(**{name: getattr(joint, name) for name in cls.__dataclass_fields__})

    def stiffening_torque(self, q, ops) -> tuple:
        """e(q) of (11.2) and e'(q), N·m and N·m/rad (``stiffening``: whether a > 0)."""
        a, beta = self.rom_torque, self.rom_sharpness
        upper = ops.exp(beta * (q - self.rom_max))
        lower = ops.exp(beta * (self.rom_min - q))
        value = a * (upper - self._upper_at_rest) - a * (lower - self._lower_at_rest)
        return value, a * beta * (upper + lower)

    def spastic_torque(self, v, ops) -> tuple:
        """s(q̇) of (11.3) and s'(q̇), N·m and N·m·s/rad (``viscous``: τ_H depends on q̇)."""
        w, threshold = SPASTICITY_WIDTH, self.spasticity_threshold
        rising_value, rising_slope = ops.softplus_and_sigmoid((v - threshold) / w)
        falling_value, falling_slope = ops.softplus_and_sigmoid((-v - threshold) / w)
        at_zero = self._spastic_at_zero
        value = self.extensor_spasticity * (w * rising_value - at_zero)
        value = value - self.spasticity * (w * falling_value - at_zero)
        slope = self.extensor_spasticity * rising_slope + self.spasticity * falling_slope
        return value, slope

    def torque(self, q, qdot, ops) -> tuple:
        """τ_H of (11.1) without the effort, ∂τ_H/∂q and ∂τ_H/∂q̇ (``qdot`` None: q̇ = 0)."""
        value = self.stiffness * (q - self.rest_angle)
        slope = self.stiffness + 0.0 * q
        rate_slope = 0.0 * q
        if self.stiffening:
            extra, extra_slope = self.stiffening_torque(q, ops)
            value, slope = value + extra, slope + extra_slope
        if self.viscous and qdot is not None:
            spastic, spastic_slope = self.spastic_torque(qdot, ops)
            value = value + self.damping * qdot + spastic
            rate_slope = self.damping + spastic_slope
        return value, slope, rate_slope


class FingerLoad:
    """τ_H(q) of one solve, with its history and effort fixed: q̇ = (q − q_prev)/Δt or 0.

    Parameters
    ----------
    laws : tuple of JointLaw
        The three joints.
    ops : backend of :mod:`._backend`
    q_previous : list of 3, optional
        Angles at the previous step, rad (floats or arrays); with ``dt`` the solve is stepped.
    dt : float, optional
        Step length Δt, s.
    effort : list of 3, optional
        Voluntary effort u per joint, N·m (floats or arrays).
    qdot : list of 3, optional
        A given joint speed, rad/s, instead of a stepped one (an inverse at a known speed).
    """

    def __init__(self, laws, ops, q_previous=None, dt=None, effort=None, qdot=None) -> None:
        self.laws, self.ops = laws, ops
        self.stepped = q_previous is not None and dt is not None
        self.q_previous, self.dt = q_previous, dt
        self.effort, self.qdot = effort, qdot
        moving = self.stepped or qdot is not None
        plain = effort is None and not any(
            law.stiffening or (law.viscous and moving) for law in laws
        )
        # The paper's linear finger (the plant's hot path): τ_H = k (q − q_r), slopes k.
        self._springs = [(law.stiffness, law.rest_angle) for law in laws] if plain else None
        self._spring_slopes = [law.stiffness for law in laws]

    def __call__(self, q) -> tuple[list, list]:
        """τ_H at ``q`` (list of 3, N·m) and ∂τ_H,k/∂q_k (list of 3, N·m/rad)."""
        if self._springs is not None:
            (k0, r0), (k1, r1), (k2, r2) = self._springs
            return [k0 * (q[0] - r0), k1 * (q[1] - r1), k2 * (q[2] - r2)], self._spring_slopes
        torques, slopes = [], []
        for k, law in enumerate(self.laws):
            if self.qdot is not None:
                value, slope, _ = law.torque(q[k], self.qdot[k], self.ops)
            elif self.stepped and law.viscous:
                qdot = (q[k] - self.q_previous[k]) / self.dt
                value, slope, rate_slope = law.torque(q[k], qdot, self.ops)
                slope = slope + rate_slope / self.dt
            else:
                value, slope, _ = law.torque(q[k], None, self.ops)
            if self.effort is not None:
                value = value - self.effort[k]
            torques.append(value)
            slopes.append(slope)
        return torques, slopes
