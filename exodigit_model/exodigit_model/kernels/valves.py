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

A step of Δt from the masses m_k and volumes V_k, V_{k−1} under openings held over it:

1. Mass balance (:func:`admit_air`, :func:`integrate_air`). Each chamber's volume is taken
   affine in time from V_k to a prediction V̂ of its end value: the line through the last two
   steps' volumes, 2V_k − V_{k−1}, its motion shortened where the last step brought the
   pressure within that motion's reach of where it can go no further (the supply, the
   atmosphere, or where the valves' flows balance; :func:`settle_air`). Along that path the
   chambers are independent scalar ODEs ṁ = F(t, m), integrated by n equal sub-steps h
   (:func:`air_steps`: at least round(T_sub/Δt), T_sub = ``SUBSTEP_TIME`` = 0.04 s, so
   h ≤ Δt²/T_sub: four at 100 Hz; more for a chamber whose pressure moves fast) of ROS2, the
   two-stage Rosenbrock W-method of Verwer, Spee, Blom and Hundsdorfer (SIAM J. Sci. Comput.
   20, 1999):

   .. math:: (1 - \gamma h J)\,k_1 = F(t_n, m_n), \quad
             (1 - \gamma h J)\,k_2 = F(t_n + h, m_n + h k_1) - 2k_1, \quad
             m_{n+1} = m_n + \tfrac32 h k_1 + \tfrac12 h k_2,

   γ = 1 + 1/√2, J = ∂F/∂m at (t_n, m_n). It is of order two for any J (a W-method) and
   L-stable with the exact J: the laminar region near equal pressures, whose time constant
   V/(R·T·∂Q/∂P) is about 2 ms with the defaults (shorter than a 10 ms step), is damped at any
   sub-step, never rung or blown up. F decreases in m (more air: less inflow, more outflow and
   leak), so 1 − γhJ ≥ 1. Alongside, the same sub-steps differentiated by V̂ (J held) give
   S = ∂m̂/∂V̂, how the end mass m̂ moves with the end volume.
2. Statics (:mod:`.statics`): solved with the chambers' pressures of the gas law (14.2) at the
   end volume V(x) of the unknowns and the end mass linearised about the prediction,
   m(x) = m̂ + S·(V(x) − V̂): p(x) = m(x)·R·T/V(x) − P_atm, whose slope in V, (S·R·T − P)/V,
   enters the Newton Jacobian (the chamber's "gas spring"). One Newton solve per step, as with
   regulators. In the laminar region S ≈ P_s/(R·T) and the supply holds the pressure whatever
   the volume does; while choked S ≈ 0 and the air is a closed spring.
3. The masses m(x), volumes V(x) and pressures of the solved x are the new state
   (:func:`settle_air`).

A step in which a chamber fills, vents or settles fast is taken as m shorter steps, each with
its own statics (:func:`air_steps`, :func:`.stepping.split_step`): the chord between volumes
cannot follow a pressure that reaches the supply early in the step.

Order. The mass balance sees the volume along the chord from V_k to V(x_{k+1}) up to the
linearisation's O((V(x) − V̂)²) = O(Δt⁴), and the chord is O(Δt²) from the true path, so a
step adds O(Δt³) to the masses: the scheme is second order in Δt. The sub-steps add O(h²)
globally, h ≤ Δt²/T_sub, or h ∝ Δt where a pressure's rate sets their number: O(Δt²) either
way. The splits and the rate bound of the sub-steps do not depend on Δt, so they shrink with
it. Measured against the DAE reference of tests/valves_reference.py
(tests/test_model_valves_convergence.py, default glove, 10 ms openings, 100/200/400 Hz):
largest pressure errors 80/23/4.8 Pa (fill, hold, vent), orders 1.79 and 2.27; over the box of
docs/valves.md at most 0.38 kPa at 50 Hz (tests/test_model_valves_corners.py).
"""

from __future__ import annotations

import math

import numpy as np

from .flow_regions import LAMINAR_RATIO
from .jit import kernel

SUBSTEP_TIME = 0.04
"""T_sub, s: a (split) step of a glove stepped at Δt takes at least n = round(T_sub/Δt) ROS2
sub-steps (:func:`air_steps`), h ≤ Δt²/T_sub: four at 100 Hz."""
SPLIT_RATE = 3e6
"""Ṗ_s, Pa/s: a step splits into m ≥ |Ṗ|/Ṗ_s steps of Δt/m (:func:`air_steps`), |Ṗ| the
fastest chamber's pressure rate at the step's start: at 100 Hz a split step moves a pressure
by at most 30 kPa at its starting rate."""
SPLIT_BEND = 7.5e3
"""ω_s, √Pa/s: a step also splits into m ≥ √(|J·Ṗ|)/ω_s (:func:`air_steps`), J = ∂ṁ/∂m: at
100 Hz the pressure's path bends away from a straight line by at most (ω_s·10 ms)² ≈ 5.6 kPa
within a split step (P̈ ≈ J·Ṗ)."""
SETTLED = 1e3
"""D_min, Pa: a chamber whose pressure lies within this of where its flows balance (by one
Newton step, D = |Ṗ/J|) does not split a step for its bend: however sharply it settles, its
path departs from a line by less than D."""
SUBSTEP_RATE = 1.0e5
"""Ṗ_h, Pa/s: the m split steps take together at least |Ṗ|/Ṗ_h sub-steps (:func:`air_steps`):
at 100 Hz a sub-step moves a pressure by at most 1 kPa at its starting rate."""
MOST_SPLITS = 64
"""m at most, and 4·:data:`MOST_SPLITS` sub-steps per split at most: the rule's rates are those
of the documented box (docs/valves.md, "Where the bound holds"); far outside it (a valve ten
times larger) they would grow without end, and such parameters are warned about anyway."""
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
GAS_VOLUME_BEFORE = 2  # V one step before, its motion shortened (settle_air), m³
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
def air_steps(air, gas, openings, period):
    """How a step of ``period`` s under ``openings`` (6,) is taken: (splits m, sub-steps n).

    Each chamber's own time scales set it, from its pressure rate Ṗ = ṁ·R·T/V and the mass
    balance's slope J = ∂ṁ/∂m (14.4) at the step's start (volume held; :func:`air_rate`):

    - m = max(1, ⌈|Ṗ|/Ṗ_s⌉, ⌈√(|J·Ṗ|)/ω_s⌉) over the chambers (:data:`SPLIT_RATE`,
      :data:`SPLIT_BEND`; the second only for a chamber further than :data:`SETTLED` from
      where its flows balance, |Ṗ/J|): the step is taken as m steps of Δt/m, each with its
      own statics. A step integrates the air along a straight line between volumes, and the
      volume follows the pressure through the pose, so its error is set by how far the
      pressure moves within it (|Ṗ|·Δt) and how far its path bends away from a line
      (|P̈|·Δt², P̈ ≈ J·Ṗ): a chamber that fills or vents within the step, or settles toward
      where its valves' flows balance, moves the volume along a path no chord follows.
    - n = max(1, round(T_sub/Δt), ⌈max|Ṗ|/(m·Ṗ_h)⌉) ROS2 sub-steps per split step
      (:data:`SUBSTEP_TIME`, :data:`SUBSTEP_RATE`): h ≤ Δt²/T_sub, and no sub-step moves a
      pressure by more than Ṗ_h·Δt at its starting rate.

    m and the rate bound of n do not depend on Δt: the split steps and sub-steps shrink with
    the step, and the error falls with the scheme's order. A chamber at rest or at the
    pressure its valves hold (Ṗ = 0) takes one step of round(T_sub/Δt) sub-steps, the scheme
    of issue 26. Both are capped (:data:`MOST_SPLITS`).
    """
    splits, fastest = 1, 0.0
    for k in range(3):
        volume = gas[GAS_VOLUME, k]
        if volume <= 0.0:
            continue
        inlet = min(max(openings[k], 0.0), 1.0)
        outlet = min(max(openings[3 + k], 0.0), 1.0)
        gas_per_volume = air[k, AIR_GAS] / volume
        rate, slope = air_rate(air[k], gas[GAS_MASS, k], gas_per_volume, inlet, outlet)
        speed = abs(rate) * gas_per_volume
        splits = max(splits, math.ceil(speed / SPLIT_RATE))
        if speed > SETTLED * abs(slope):
            splits = max(splits, math.ceil(math.sqrt(speed * abs(slope)) / SPLIT_BEND))
        fastest = max(fastest, speed)
    splits = min(splits, MOST_SPLITS)
    count = max(1, round(SUBSTEP_TIME / period), math.ceil(fastest / (splits * SUBSTEP_RATE)))
    return splits, min(count, 4 * MOST_SPLITS)


@kernel(counted=False)
def integrate_air(air, masses, start, end, openings, period, count, scratch, slopes):
    """The chambers' air masses (3,), kg, over a step of ``period`` s, in place (ROS2, above).

    Chamber k's volume goes from ``start[k]`` to ``end[k]`` (m³) affinely in time under the
    ``openings`` (6,) held over the step, in ``count`` ROS2 sub-steps (:func:`air_steps`);
    ``scratch`` (5, 3) is work space. Into ``slopes``
    (3,), kg/m³: ∂m/∂V̂, how each new mass moves with the end volume V̂ (the sub-steps
    differentiated with each sub-step's J held, as the W-method allows). The three chambers
    advance together, stage by stage: their chains of divisions and roots are independent, and
    so overlap in the processor. Called, not inlined (:func:`.jit.kernel`): compiled once
    instead of once more in every stepping kernel, for a call of a few tens of ns per step.
    """
    h = period / count
    first, shrink, moved, held, inverse = scratch
    for k in range(3):
        slopes[k] = 0.0
        inverse[k] = 1.0 / start[k]  # 1/V where the sub-step starts
    for n in range(count):
        for k in range(3):
            across = inverse[k]
            gas, mass = air[k, AIR_GAS] * across, masses[k]
            rate, held[k] = air_rate(air[k], mass, gas, openings[k], openings[3 + k])
            shrink[k] = 1.0 / (1.0 - ROS2_GAMMA * h * held[k])
            first[k] = rate * shrink[k]
            # d/dV̂ of F(m, V): J·(dm/dV̂ − (m/V)·dV/dV̂), dV/dV̂ = n/count at this stage
            moved[k] = shrink[k] * held[k] * (slopes[k] - mass * across * n / count)
        for k in range(3):
            across = 1.0 / (start[k] + (n + 1) * (end[k] - start[k]) / count)
            inverse[k] = across
            gas, mass = air[k, AIR_GAS] * across, masses[k] + h * first[k]
            rate, _ = air_rate(air[k], mass, gas, openings[k], openings[3 + k])
            second = (rate - 2.0 * first[k]) * shrink[k]
            masses[k] += h * (1.5 * first[k] + 0.5 * second)
            carried = slopes[k] + h * moved[k] - mass * across * (n + 1) / count
            along = shrink[k] * (held[k] * carried - 2.0 * moved[k])
            slopes[k] += h * (1.5 * moved[k] + 0.5 * along)


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

    In round(T_sub/Δt) sub-steps (:data:`SUBSTEP_TIME`), whatever the chambers.

    ``masses``, ``start`` and ``end`` (3,): kg, m³, m³; ``openings`` (6,): u_in, then u_out
    (MCP, PIP, DIP), each within [0, 1]; ``period``: s.
    """
    result = masses.copy()
    count = max(1, round(SUBSTEP_TIME / period))
    scratch, slopes = np.empty((5, 3)), np.empty(3)
    integrate_air(air, result, start, end, openings, period, count, scratch, slopes)
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
def end_mass(masses, slopes, predicted, k, volume):
    """Chamber k's air mass at the end volume ``volume`` (m³), kg: linear about V̂."""
    return masses[k] + slopes[k] * (volume - predicted[k])


@kernel(counted=False, forceinline=True)
def gas_pressures(air, masses, slopes, predicted, x, gauge, spring):
    """The gauge pressures of the gas law (14.2) at the unknowns ``x`` into ``gauge``, Pa.

    The masses are those of the step at the volumes of ``x`` (:func:`end_mass`: ``masses`` at
    the predicted volumes, ``slopes`` ∂m/∂V̂). Their slopes ∂p/∂V into ``spring``, Pa/m³:
    (∂m/∂V̂·R·T − P)/V. A chamber without volume gets no finite pressure.
    """
    for k in range(3):
        volume = chamber_volume(air[k], x, k)
        absolute, spring[k] = math.inf, 0.0
        if volume > 0.0:
            mass = end_mass(masses, slopes, predicted, k, volume)
            absolute = absolute_pressure(air[k], mass, volume)
            spring[k] = (slopes[k] * air[k, AIR_GAS] - absolute) / volume
        gauge[k] = absolute - air[k, AIR_ATMOSPHERE]


@kernel(counted=False, forceinline=True)
def admit_air(work, air, gas, new_gas, openings, applied, period, count):
    """The first half of a valve step: openings clipped, masses integrated over the step.

    ``openings`` (6,) are clipped to [0, 1] into ``applied``; each chamber's mass goes from
    ``gas`` to ``new_gas`` (rows ``GAS_*``) by :func:`integrate_air` along the volume's path
    from its value to 2V_k − V_{k−1} (its value where that is not positive) in ``count``
    sub-steps, and with the
    constants ``air`` into ``work`` for the statics' gas law. Returns whether an opening was
    below zero and whether one was above one.
    """
    below, above = admit(openings, applied)
    masses, predicted = work.masses, work.predicted
    for k in range(3):
        volume = gas[GAS_VOLUME, k]
        predicted[k] = 2.0 * volume - gas[GAS_VOLUME_BEFORE, k]
        if predicted[k] <= 0.0:
            predicted[k] = volume
        masses[k] = gas[GAS_MASS, k]
        for column in range(AIR_COLUMNS):
            work.air[k, column] = air[k, column]
    scratch, slopes = work.air_scratch, work.mass_slopes
    volume = gas[GAS_VOLUME]
    integrate_air(air, masses, volume, predicted, applied, period, count, scratch, slopes)
    return below, above


@kernel(counted=False, forceinline=True)
def room_ahead(row, mass, volume, moved, inlet, outlet):
    """How far (Pa) a chamber's pressure, which just moved by ``moved``, can go on that way.

    To the supply (rising) or the atmosphere (falling), and no further than where the flows of
    (14.4) under the openings ``inlet``, ``outlet`` balance, by one Newton step from the mass
    ``mass`` (kg) in ``volume`` (m³): |ṁ/J|·R·T/V. Zero when the flows drive it back; infinite
    when it did not move or no flow depends on its pressure (valves closed, no leak).
    """
    gas_per_volume = row[AIR_GAS] / volume
    rate, slope = air_rate(row, mass, gas_per_volume, inlet, outlet)
    if moved == 0.0 or slope >= 0.0:
        return math.inf
    if rate * moved <= 0.0:
        return 0.0
    absolute = mass * gas_per_volume
    edge = row[AIR_SUPPLY] - absolute if moved > 0.0 else absolute - row[AIR_ATMOSPHERE]
    return max(min(edge, abs(rate / slope) * gas_per_volume), 0.0)


@kernel(counted=False, forceinline=True)
def settle_air(work, air, gas, new_gas, x, pressure, still, scale, applied):
    """The second half of a valve step: masses, volumes and gauge pressures at the solved ``x``.

    Into ``new_gas`` the masses at the volumes of ``x`` (:func:`end_mass`, from what
    :func:`admit_air` left in ``work``) and those volumes; into ``pressure`` the gauge
    pressures of the gas law (Pa), as the statics had them. The row ``GAS_VOLUME_BEFORE``,
    which the next step extrapolates from (its prediction 2V − V_before), gets V − s·ΔV: the
    step's volume motion ΔV, ``scale`` times over (the last split step of
    :func:`.stepping.split_step` hands a whole step this many times as long to the next), and
    shortened to s = room/|ΔP| (:func:`room_ahead`) where the pressure moved by ΔP but can go
    only ``room`` further the same way under ``applied`` (6,). A chamber that filled within
    the step is not predicted to swell on as far again. The volumes stay where the glove is
    ``still`` (its solve failed).
    """
    masses, slopes, predicted = work.masses, work.mass_slopes, work.predicted
    for k in range(3):
        volume = chamber_volume(air[k], x, k)
        mass = end_mass(masses, slopes, predicted, k, volume)
        new_gas[GAS_MASS, k] = mass
        absolute = absolute_pressure(air[k], mass, volume)
        pressure[k] = absolute - air[k, AIR_ATMOSPHERE]
        before = gas[GAS_VOLUME, k]
        moved = absolute - absolute_pressure(air[k], gas[GAS_MASS, k], before)
        room = room_ahead(air[k], mass, volume, moved, applied[k], applied[3 + k])
        share = scale if scale * abs(moved) <= room else room / abs(moved)
        new_gas[GAS_VOLUME_BEFORE, k] = volume if still else volume - (volume - before) * share
        new_gas[GAS_VOLUME, k] = volume
