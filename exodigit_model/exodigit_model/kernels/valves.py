r"""The chambers' air behind valves (docs/spec/model.md §14): flow, mass balance, volume.

Each chamber i holds the air mass m_i (kg) at the absolute pressure P_i = m_i·R·T/V_i
(isothermal, (14.2)); its volume is affine in the unknowns of the statics,

.. math:: V_i = V_{d,i} + A_{c,i}\,\ell_i + (r_pA_p)_i\,q_i \qquad (14.1)

(ℓ_i = ℓ̂_i·(1 + ε_i)), so that p·∂V/∂q = τ_p. The valves pass the ISO 6358-3 mass flow

.. math:: Q(P_u, P_d) = C\rho_0 P_u\sqrt{T_0/T}\,\psi(P_d/P_u), \qquad
          Q(P_d, P_u) = -Q(P_u, P_d) \qquad (14.3)

with ψ = 1 (r ≤ b, choked), √(1 − ((r − b)/(1 − b))²) (b < r ≤ 0.999) and
ψ(0.999)·(1 − r)/(1 − 0.999) (laminar, r > 0.999), and the mass balance is

.. math:: \dot m_i = u_{in,i}\,Q(P_s, P_i) - u_{out,i}\,Q(P_i, P_{atm})
          - G_i\,(P_i - P_{atm}). \qquad (14.4)

Integration over one step (:func:`integrate_air`). Over a step of Δt the volume of each chamber
is taken affine in time, from its value V_k at the step's start to a prediction V̂ of its value
at the end; given that path the chambers are independent scalar ODEs ṁ = F(t, m), which
:func:`integrate_air` integrates by ``SUBSTEPS`` equal sub-steps h of ROS2, the two-stage
Rosenbrock W-method of Verwer, Spee, Blom and Hundsdorfer (SIAM J. Sci. Comput. 20, 1999):

.. math:: (1 - \gamma h J)\,k_1 = F(t_n, m_n), \quad
          (1 - \gamma h J)\,k_2 = F(t_n + h, m_n + h k_1) - 2k_1, \quad
          m_{n+1} = m_n + \tfrac32 h k_1 + \tfrac12 h k_2,

γ = 1 + 1/√2, J = ∂F/∂m at (t_n, m_n). It is of order two for any J (a W-method: the kinks of ψ
at r = b and r = 0.999 and the time-dependent volume cost no order) and L-stable with the exact
J: the laminar region near equal pressures, where the time constant V/(R·T·∂Q/∂P) is about
2 ms with the defaults (shorter than a 10 ms step), is damped at any sub-step, never rung or
blown up. F decreases in m (more air: less inflow, more outflow and leak), so 1 − γhJ ≥ 1.

The mass at the end of the step then enters the statics through the gas law (14.2), solved with
them by the Newton iteration (:mod:`.statics`, the "gas spring" of the chamber); the end volume
prediction is V̂ = 2V_k − V_{k−1}, the line through the last two steps' volumes (exact for a
volume moving at a constant speed). Order: the mass balance sees the volume path with an error of
O(Δt²) (the chord of a smooth path, and the prediction), so each step adds O(Δt³) to the masses,
and the ROS2 sub-steps O((Δt/SUBSTEPS)³): the masses, and so the pressures and angles, are
second-order accurate in Δt. A step where the openings change has a kink in the volume's path, an
O(Δt²) error once. The explicit prediction is stable: linearised about a chamber in equilibrium
with its supply, its error obeys e_{k+1} = g·(2e_k − e_{k−1}) with g = a/(1 + a) < 1 (a = P·c/V,
c = ∂V/∂P of the statics), whose roots have modulus √g < 1.
"""

from __future__ import annotations

import math

import numpy as np

from .jit import kernel

LAMINAR_RATIO = 0.999
"""Pressure ratio above which the flow of (14.3) is laminar (linear in the pressure drop)."""
SUBSTEPS = 4
"""ROS2 sub-steps of the mass balance per step (:func:`integrate_air`)."""
ROS2_GAMMA = 1.0 + 1.0 / math.sqrt(2.0)
"""γ of ROS2 (L-stable)."""

# Columns of a chamber's row of pneumatic constants (``air``, one row per chamber, SI).
AIR_INLET_CONDUCTANCE = 0  # C of the inlet valve, m³/(s·Pa)
AIR_INLET_CRITICAL = 1  # b of the inlet valve
AIR_OUTLET_CONDUCTANCE = 2  # C of the outlet valve, m³/(s·Pa)
AIR_OUTLET_CRITICAL = 3  # b of the outlet valve
AIR_LEAK = 4  # G, kg/(s·Pa)
AIR_VOLUME = 5  # V at q = 0 and ℓ = ℓ̂: V_d + A_c·ℓ̂, m³
AIR_VOLUME_PER_STRAIN = 6  # ∂V/∂ε = A_c·ℓ̂, m³
AIR_VOLUME_PER_ANGLE = 7  # ∂V/∂q = r_p·A_p, m³/rad
AIR_GAS = 8  # R·T, J/kg
AIR_ATMOSPHERE = 9  # P_atm, Pa (absolute)
AIR_SUPPLY = 10  # P_s, Pa (absolute)
AIR_DENSITY = 11  # ρ0·√(T0/T), kg/m³
AIR_COLUMNS = 12

# Rows of a glove's air state (``gas``, one column per chamber).
GAS_MASS = 0  # m, kg
GAS_VOLUME = 1  # V at the state, m³
GAS_VOLUME_BEFORE = 2  # V one step before, m³
GAS_ROWS = 3


@kernel(counted=False, forceinline=True)
def flow_function(r, critical):
    """ψ(r) of (14.3) for b = ``critical`` and dψ/dr, for 0 ≤ r ≤ 1."""
    if r <= critical:
        return 1.0, 0.0
    span = 1.0 - critical
    if r <= LAMINAR_RATIO:
        s = (r - critical) * (1.0 / span)  # a product on the chain, the quotient hoisted
        psi = math.sqrt(1.0 - s * s)
        return psi, -s / (span * psi)
    s = (LAMINAR_RATIO - critical) / span
    slope = -math.sqrt(1.0 - s * s) / (1.0 - LAMINAR_RATIO)
    return slope * (r - 1.0), slope


@kernel(counted=False, forceinline=True)
def mass_flow(conductance, critical, upstream, downstream, density):
    """Q of (14.3), kg/s, and its partial derivatives ∂Q/∂P_u, ∂Q/∂P_d (kg/(s·Pa)).

    ``density`` is ρ0·√(T0/T); the pressures are absolute (Pa). Q(P_d, P_u) = −Q(P_u, P_d):
    air flows from the higher pressure to the lower one.
    """
    high, low = max(upstream, downstream), min(upstream, downstream)
    if high <= 0.0:
        return 0.0, 0.0, 0.0
    r = low / high
    psi, slope = flow_function(r, critical)
    scale = conductance * density
    value, by_high, by_low = scale * high * psi, scale * (psi - r * slope), scale * slope
    if upstream >= downstream:
        return value, by_high, by_low
    return -value, -by_low, -by_high


@kernel(counted=False, forceinline=True)
def air_rate(row, mass, gas_per_volume, inlet, outlet):
    """ṁ of (14.4), kg/s, and ∂ṁ/∂m (1/s) of one chamber: openings ``inlet``, ``outlet``.

    ``gas_per_volume`` is R·T/V, J/(kg·m³): P = m·R·T/V.
    """
    atmosphere = row[AIR_ATMOSPHERE]
    pressure = mass * gas_per_volume
    leak = row[AIR_LEAK]
    rate = -leak * (pressure - atmosphere)
    slope = -leak
    if inlet > 0.0:
        q, _, by_chamber = mass_flow(
            row[AIR_INLET_CONDUCTANCE],
            row[AIR_INLET_CRITICAL],
            row[AIR_SUPPLY],
            pressure,
            row[AIR_DENSITY],
        )
        rate += inlet * q
        slope += inlet * by_chamber
    if outlet > 0.0:
        q, by_chamber, _ = mass_flow(
            row[AIR_OUTLET_CONDUCTANCE],
            row[AIR_OUTLET_CRITICAL],
            pressure,
            atmosphere,
            row[AIR_DENSITY],
        )
        rate -= outlet * q
        slope -= outlet * by_chamber
    return rate, slope * gas_per_volume


@kernel(counted=False, forceinline=True)
def integrate_air(air, masses, start, end, openings, period, scratch):
    """The chambers' air masses (3,), kg, over a step of ``period`` s, in place (ROS2, above).

    Chamber k's volume goes from ``start[k]`` to ``end[k]`` (m³) affinely in time under the
    ``openings`` (6,) held over the step; ``scratch`` (2, 3) is work space. The three chambers
    advance together, stage by stage: their chains of divisions and roots are independent, and
    so overlap in the processor.
    """
    h = period / SUBSTEPS
    first, shrink = scratch[0], scratch[1]
    for n in range(SUBSTEPS):
        for k in range(3):
            volume = start[k] + n * (end[k] - start[k]) / SUBSTEPS
            gas = air[k, AIR_GAS] / volume
            rate, slope = air_rate(air[k], masses[k], gas, openings[k], openings[3 + k])
            shrink[k] = 1.0 / (1.0 - ROS2_GAMMA * h * slope)
            first[k] = rate * shrink[k]
        for k in range(3):
            volume = start[k] + (n + 1) * (end[k] - start[k]) / SUBSTEPS
            gas = air[k, AIR_GAS] / volume
            mass = masses[k] + h * first[k]
            rate, _ = air_rate(air[k], mass, gas, openings[k], openings[3 + k])
            second = (rate - 2.0 * first[k]) * shrink[k]
            masses[k] += h * (1.5 * first[k] + 0.5 * second)


@kernel(counted=False, forceinline=True)
def chamber_volume(row, x, k):
    """V_k of (14.1) at the unknowns ``x`` (q, and ε with extensible segments), m³."""
    volume = row[AIR_VOLUME] + row[AIR_VOLUME_PER_ANGLE] * x[k]
    if x.size == 6:
        volume += row[AIR_VOLUME_PER_STRAIN] * x[3 + k]
    return volume


@kernel(counted=False, forceinline=True)
def admit(openings, applied):
    """``openings`` (6,) clipped to [0, 1] into ``applied``; whether any was below, above."""
    below = above = False
    for k in range(6):
        value = openings[k]
        if value < 0.0:
            below, value = True, 0.0
        elif value > 1.0:
            above, value = True, 1.0
        applied[k] = value
    return below, above


@kernel
def advance_masses(air, masses, start, end, openings, period):
    """:func:`integrate_air` from Python: the chambers' (rows of ``air``) new masses.

    ``masses``, ``start`` and ``end`` (3,): kg, m³, m³; ``openings`` (6,): u_in, then u_out
    (MCP, PIP, DIP), each within [0, 1]; ``period``: s.
    """
    result = masses.copy()
    integrate_air(air, result, start, end, openings, period, np.empty((2, 3)))
    return result


@kernel
def flow_of(conductance, critical, upstream, downstream, density):
    """:func:`mass_flow` from Python: Q (kg/s) alone."""
    return mass_flow(conductance, critical, upstream, downstream, density)[0]


@kernel
def flow_function_of(r, critical):
    """:func:`flow_function` from Python: ψ alone."""
    return flow_function(r, critical)[0]


@kernel(counted=False, forceinline=True)
def absolute_pressure(row, mass, volume):
    """P = m·R·T/V of (14.2), Pa (absolute), for a volume > 0 (m³)."""
    return mass * row[AIR_GAS] / volume


@kernel(counted=False, forceinline=True)
def admit_air(work, air, gas, new_gas, openings, applied, period):
    """The first half of a valve step: openings clipped, masses integrated over the step.

    ``openings`` (6,) are clipped to [0, 1] into ``applied``; each chamber's mass goes from
    ``gas`` to ``new_gas`` (rows ``GAS_*``) by :func:`integrate_air` along the volume's path
    from its value to 2V_k − V_{k−1} (its value where that is not positive), and with the
    constants ``air`` into ``work`` for the statics' gas law. Returns whether an opening was
    below zero and whether one was above one.
    """
    below, above = admit(openings, applied)
    masses, predicted = work.masses, work.air_scratch[0]
    for k in range(3):
        volume = gas[GAS_VOLUME, k]
        predicted[k] = 2.0 * volume - gas[GAS_VOLUME_BEFORE, k]
        if predicted[k] <= 0.0:
            predicted[k] = volume
        masses[k] = gas[GAS_MASS, k]
        for column in range(AIR_COLUMNS):
            work.air[k, column] = air[k, column]
    integrate_air(air, masses, gas[GAS_VOLUME], predicted, applied, period, work.air_scratch[1:])
    for k in range(3):
        new_gas[GAS_MASS, k] = masses[k]
    return below, above


@kernel(counted=False, forceinline=True)
def settle_air(air, gas, new_gas, x, pressure, still):
    """The second half of a valve step: volumes and gauge pressures at the solved ``x``.

    Into ``new_gas`` the volume at ``x`` and the one before it (``gas``'s, or the same volume
    where the glove is ``still``: its solve failed), into ``pressure`` the gauge pressures of
    the gas law at the new masses (Pa).
    """
    for k in range(3):
        volume = chamber_volume(air[k], x, k)
        absolute = absolute_pressure(air[k], new_gas[GAS_MASS, k], volume)
        pressure[k] = absolute - air[k, AIR_ATMOSPHERE]
        new_gas[GAS_VOLUME_BEFORE, k] = volume if still else gas[GAS_VOLUME, k]
        new_gas[GAS_VOLUME, k] = volume
