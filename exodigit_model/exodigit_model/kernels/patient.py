r"""The patient's joint torque τ_H of eqs (11.1)-(11.3) (docs/spec/model.md §11), per joint.

.. math::

    \tau_H = k\,(q - q_r) + e(q) + c\,\dot q + s(\dot q) - u \qquad (11.1)

    e(q) = a\,[e^{\beta(q - q_{max})} - e^{\beta(q_r - q_{max})}]
         - a\,[e^{\beta(q_{min} - q)} - e^{\beta(q_{min} - q_r)}] \qquad (11.2)

    s(v) = g_e\,[S(v) - S(0)] - g_f\,[S(-v) - S(0)], \quad
    S(v) = w \ln(1 + e^{(v - v_t)/w}) \qquad (11.3)

(w = ``SPASTICITY_WIDTH``). A stepped solve has q̇ = (q − q_prev)/Δt inside the equation, so
∂τ_H/∂q = k + e'(q) + (c + s'(q̇))/Δt; a static one has q̇ = 0. With every parameter of §11 at
its default τ_H = k·q: eq 32 of the paper. The constants are the rows of
``GloveConstants.laws`` (columns ``LAW_*`` of :mod:`.constants`).
"""

from __future__ import annotations

import math

from .constants import (
    LAW_DAMPING,
    LAW_EXTENSOR_SPASTICITY,
    LAW_LOWER_AT_REST,
    LAW_REST_ANGLE,
    LAW_ROM_MAX,
    LAW_ROM_MIN,
    LAW_ROM_SHARPNESS,
    LAW_ROM_TORQUE,
    LAW_SPASTIC_AT_ZERO,
    LAW_SPASTICITY,
    LAW_SPASTICITY_THRESHOLD,
    LAW_STIFFNESS,
    LAW_UPPER_AT_REST,
)
from .jit import kernel

SPASTICITY_WIDTH = 0.01
"""w of eq (11.3): the velocity over which the spastic resistance switches on, rad/s."""
MAX_EXPONENT = 700.0
"""Largest exponent passed to exp (e^700 ≈ 1e304: finite, so a wild trial state stays finite)."""


@kernel(counted=False, forceinline=True)
def softplus_and_sigmoid(x):
    """ln(1 + eˣ) and its slope 1/(1 + e⁻ˣ), from one exponential, without overflow."""
    z = math.exp(-abs(x))
    return max(x, 0.0) + math.log1p(z), (1.0 if x >= 0.0 else z) / (1.0 + z)


@kernel(counted=False, forceinline=True)
def finger_torque(law, q, qdot, rate):
    """τ_H of (11.1) without the effort (N·m) and its slope dτ_H/dq (N·m/rad) at one joint.

    Parameters
    ----------
    law : ndarray, shape (LAW_COLUMNS,)
        The joint's row of ``GloveConstants.laws``.
    q, qdot : float
        Angle, rad, and speed, rad/s.
    rate : float
        dq̇/dq: 1/Δt in a stepped solve, 0 where the speed is given.
    """
    value = law[LAW_STIFFNESS] * (q - law[LAW_REST_ANGLE])
    slope = law[LAW_STIFFNESS]
    a = law[LAW_ROM_TORQUE]
    if a > 0.0:
        beta = law[LAW_ROM_SHARPNESS]
        upper = math.exp(min(beta * (q - law[LAW_ROM_MAX]), MAX_EXPONENT))
        lower = math.exp(min(beta * (law[LAW_ROM_MIN] - q), MAX_EXPONENT))
        value += a * (upper - law[LAW_UPPER_AT_REST]) - a * (lower - law[LAW_LOWER_AT_REST])
        slope += a * beta * (upper + lower)
    flexors, extensors = law[LAW_SPASTICITY], law[LAW_EXTENSOR_SPASTICITY]
    damping = law[LAW_DAMPING]
    if (qdot != 0.0 or rate != 0.0) and (damping > 0.0 or flexors > 0.0 or extensors > 0.0):
        w, threshold = SPASTICITY_WIDTH, law[LAW_SPASTICITY_THRESHOLD]
        at_zero = law[LAW_SPASTIC_AT_ZERO]
        # A side without spasticity adds zero (most patients: extensors 0, docs/patients.md),
        # so its softplus (an exp and a log each) is not computed.
        extending = extending_slope = flexing = flexing_slope = 0.0
        if extensors > 0.0:
            rising, rising_slope = softplus_and_sigmoid((qdot - threshold) / w)
            extending, extending_slope = (
                extensors * (w * rising - at_zero),
                extensors * rising_slope,
            )
        if flexors > 0.0:
            falling, falling_slope = softplus_and_sigmoid((-qdot - threshold) / w)
            flexing, flexing_slope = flexors * (w * falling - at_zero), flexors * falling_slope
        value += damping * qdot + (extending - flexing)
        slope += (damping + extending_slope + flexing_slope) * rate
    return value, slope
