r"""The coupled quasi-statics at one state: residual, contact forces and analytic Jacobian.

Inextensible segments (eqs 31, 34-36, docs/spec/model.md §7, §11): the unknowns are the
angles q and

.. math::

    F(q, p) = \tau_s(q) + B_R\,p - (J_R^*)^T f = 0, \qquad
    f = (J_H^*)^{-T}\,\tau_H(q, \dot q, u)  \qquad (36, 11.4)

with the Jacobian

.. math::

    \frac{\partial F_k}{\partial q_m} = \delta_{km}\tau_{s,k}'
      - \sum_i \frac{\partial J^*_{R,ik}}{\partial q_m} f_i - \sum_i J^*_{R,ik}
      \frac{\partial f_i}{\partial q_m}, \qquad
    (J_H^*)^T\frac{\partial f}{\partial q_m} = \frac{\partial \tau_{H,m}}{\partial q_m} e_m
      - \Bigl(\frac{\partial J_H^*}{\partial q_m}\Bigr)^T f.

Extensible segments (§12): the unknowns are x = (q, ε), ε_k = λ_b,k − 1, and the rows are

.. math::

    R_k = -M_k + (r_pA_p)_k p_k - [(J_R^*)^T f]_k \qquad (12.4)

    S_k = \hat\ell_k \bigl(-N_k - E_{L,k} \varepsilon_k + A_{p,k} p_k
          - [(J_\ell^*)^T f]_k\bigr) \qquad (12.5)

(12.5) is written as the generalized force conjugate to ε (the factor ℓ̂_k = ∂ℓ_k/∂ε_k) so
that all six rows are in N·m; an inextensible segment of a mixed glove keeps the row ε_k = 0.
The finger side depends on q only, so ∂f/∂ε = 0. With no finger (free motion) f = 0.

Every residual is affine in p, and each row is judged against the size of the terms it is made
of (``scale``, what :mod:`.newton` compares the residual norm with).

Valves (docs/spec/model.md §14): chambers whose air masses m are given (``work.masses``, zero
in a fresh workspace: none) have the pressures of the gas law at the unknowns,
p(x) = m·R·T/V(x) − P_atm (14.1, 14.2), instead of given ones; the Jacobian gains the
chambers' "gas spring" ∂τ/∂p·∂p/∂V·∂V/∂x, with ∂p/∂V = −m·R·T/V², ∂V/∂q = r_pA_p and
∂V/∂ε = A_c·ℓ̂ (:func:`gas_spring`).
"""

from __future__ import annotations

import math

from .jit import kernel
from .kinematics import finger_terms, robot_jacobians, robot_slopes_of
from .linear import transpose_product, transpose_solve
from .patient import finger_torque
from .section import resultants
from .structural import structural_torque
from .valves import AIR_VOLUME_PER_ANGLE, AIR_VOLUME_PER_STRAIN, gas_pressures


@kernel(counted=False, forceinline=True)
def finger_load(glove, q, motion, rate, torque, slopes):
    """τ_H of (11.1) at ``q`` into ``torque`` (N·m), dτ_H,k/dq_k into ``slopes`` (N·m/rad).

    ``motion`` rows: the previous angles q_prev (rad), a given speed v (rad/s) and the effort u
    (N·m); q̇ = v + (q − q_prev)·rate, with ``rate`` = 1/Δt in a stepped solve (v = 0) and 0
    in a static one or at a given speed.
    """
    laws = glove.laws
    for k in range(3):
        speed = motion[1, k] + (q[k] - motion[0, k]) * rate
        value, slopes[k] = finger_torque(laws[k], q[k], speed, rate)
        torque[k] = value - motion[2, k]


@kernel(counted=False)
def evaluate(glove, work, x, pressure, free, motion, rate, residual, jacobian, forces, torque):
    """F (or (R, S)) at unknowns ``x`` into ``residual``, ∂/∂x into ``jacobian``; the scale.

    :func:`residual_of`, then :func:`jacobian_of`.

    Parameters
    ----------
    glove : GloveConstants
    work : Workspace
        Scratch (:mod:`.workspace`).
    x : ndarray, shape (3,) or (6,)
        q (rad), and ε with extensible segments (``glove.extensible``).
    pressure : ndarray, shape (3,)
        Chamber pressures, Pa.
    free : bool
        No finger (paper §3.3): f = 0.
    motion, rate : ndarray (3, 3), float
        The finger's history, speed and effort (:func:`finger_load`).
    residual, jacobian, forces, torque : ndarray
        Filled: the rows (N·m), their Jacobian, f (N) and τ_H (N·m).

    Returns
    -------
    float
        ‖|terms|‖: the norm of the per-row sums of the absolute terms, N·m.
    """
    scale = residual_of(glove, work, x, pressure, free, motion, rate, residual, forces, torque)
    jacobian_of(glove, work, x, free, jacobian, forces)
    return scale


@kernel(counted=False, forceinline=True)
def residual_of(glove, work, x, pressure, free, motion, rate, residual, forces, torque):
    """F (or (R, S)) at ``x`` into ``residual``, f and τ_H; the scale (:func:`evaluate`).

    Leaves in ``work`` what :func:`jacobian_of` needs for the Jacobian at this ``x``: a
    Newton iteration asks for the Jacobian only where it takes its next step from.
    """
    extensible = x.size == 6
    rest = glove.arc_lengths
    lengths, tau, tau_slope = work.lengths, work.tau, work.tau_slope
    moment_rate, axial, force_rate = work.moment_rate, work.axial, work.force_rate
    coupling, stretching = work.coupling, work.stretching
    # Arrays are taken out of the named tuples once, here: inside a loop every access would
    # cost a reference count pair (most of an evaluation's time, measured).
    segments_stretch = glove.extensible_segments
    layer_stiffness, moments, areas = (
        glove.layer_stiffness,
        glove.pressure_moments,
        glove.pressure_areas,
    )
    for k in range(3):
        if extensible:
            lengths[k] = rest[k] * (1.0 + x[3 + k])
            moment, axial[k], moment_slope, moment_rate[k], force_rate[k] = resultants(
                glove, k, x[k], x[3 + k]
            )
            tau[k], tau_slope[k] = -moment, -moment_slope
        else:
            lengths[k] = rest[k]
            tau[k], tau_slope[k] = structural_torque(glove, k, x[k])
    coupling[:] = 0.0
    stretching[:] = 0.0
    if free:
        forces[:] = 0.0
        torque[:] = 0.0
    else:
        q = x[:3]
        robot_jacobians(q, lengths, glove.block_half_lengths, extensible, work)
        finger_terms(q, glove.finger_half_lengths, work.j_finger, work.finger_slopes)
        finger_load(glove, q, motion, rate, torque, work.load_slopes)
        transpose_solve(work.j_finger, torque, forces)
        transpose_product(work.j_robot, forces, coupling)
        if extensible:
            transpose_product(work.j_length, forces, stretching)
    total = 0.0
    gauge = pressure
    if work.masses[0] > 0.0:  # behind valves: the gas law (14.2) at x
        gas_pressures(
            work.air, work.masses, work.mass_slopes, work.predicted, x, work.gauge, work.spring
        )
        gauge = work.gauge
    for k in range(3):
        drive = moments[k] * gauge[k]
        residual[k] = tau[k] + drive - coupling[k]
        size = abs(tau[k]) + abs(drive) + abs(coupling[k])
        total += size * size
    if extensible:
        for k in range(3):
            if segments_stretch[k]:
                layer = layer_stiffness[k] * x[3 + k]
                area = areas[k] * gauge[k]
                residual[3 + k] = rest[k] * (-axial[k] - layer + area - stretching[k])
                size = rest[k] * (abs(axial[k]) + abs(layer) + abs(area) + abs(stretching[k]))
                total += size * size
            else:
                residual[3 + k] = x[3 + k]
    return math.sqrt(total)


@kernel(counted=False, forceinline=True)
def jacobian_of(glove, work, x, free, jacobian, forces):
    """∂F/∂x at ``x`` into ``jacobian``, from what :func:`residual_of` left in ``work``.

    The last :func:`residual_of` must have been at this ``x`` and ``free``, with these
    ``forces``.
    """
    extensible = x.size == 6
    rest = glove.arc_lengths
    lengths, tau_slope, moment_rate, force_rate = (
        work.lengths,
        work.tau_slope,
        work.moment_rate,
        work.force_rate,
    )
    segments_stretch, layer_stiffness = glove.extensible_segments, glove.layer_stiffness
    jacobian[:, :] = 0.0
    if free:
        for m in range(3):
            jacobian[m, m] = tau_slope[m]
    else:
        robot_slopes_of(lengths, work)
        j_robot, j_length, j_finger = work.j_robot, work.j_length, work.j_finger
        robot_slopes, length_slopes = work.robot_slopes, work.length_slopes
        robot_length_slopes = work.robot_length_slopes
        finger_slopes, load_slopes = work.finger_slopes, work.load_slopes
        rhs, force_slope, column = work.rhs, work.force_slope, work.column
        for m in range(3):
            for k in range(3):
                rhs[k] = load_slopes[k] if k == m else 0.0
                for i in range(3):
                    rhs[k] -= finger_slopes[m, i, k] * forces[i]
            transpose_solve(j_finger, rhs, force_slope)
            transpose_product(j_robot, force_slope, column)
            for k in range(3):
                value = -column[k]
                for i in range(3):
                    value -= robot_slopes[m, i, k] * forces[i]
                jacobian[k, m] = value + (tau_slope[m] if k == m else 0.0)
            if extensible:
                transpose_product(j_length, force_slope, column)
                for k in range(3):
                    if segments_stretch[k]:
                        value = -column[k]
                        for i in range(3):
                            value -= length_slopes[m, i, k] * forces[i]
                        jacobian[3 + k, m] = rest[k] * value
                for k in range(3):
                    for i in range(3):
                        slope = robot_length_slopes[m, i, k]
                        jacobian[k, 3 + m] -= rest[m] * slope * forces[i]
    if extensible:
        for m in range(3):
            jacobian[m, 3 + m] -= moment_rate[m]  # ∂R_m/∂ε_m = −∂M_m/∂ε_m
            if segments_stretch[m]:
                jacobian[3 + m, m] -= moment_rate[m]  # ℓ̂ ∂N/∂q = ∂M/∂ε
                jacobian[3 + m, 3 + m] = -rest[m] * (force_rate[m] + layer_stiffness[m])
            else:
                jacobian[3 + m, 3 + m] = 1.0
    if work.masses[0] > 0.0:  # behind valves: the gas spring, ∂p/∂x through V (14.1)
        gas_spring(glove, work.air, work.spring, extensible, jacobian)


@kernel(counted=False, forceinline=True)
def gas_spring(glove, air, spring, extensible, jacobian):
    """The gas spring of (14.2) added to ``jacobian``: ∂τ/∂p·∂p/∂V·∂V/∂x per chamber.

    ``spring`` holds ∂p/∂V at the last :func:`residual_of`'s x (:func:`.valves.gas_pressures`).
    """
    rest, moments, areas = glove.arc_lengths, glove.pressure_moments, glove.pressure_areas
    segments_stretch = glove.extensible_segments
    for m in range(3):
        by_angle = spring[m] * air[m, AIR_VOLUME_PER_ANGLE]
        jacobian[m, m] += moments[m] * by_angle
        if extensible:
            by_strain = spring[m] * air[m, AIR_VOLUME_PER_STRAIN]
            jacobian[m, 3 + m] += moments[m] * by_strain
            if segments_stretch[m]:
                jacobian[3 + m, m] += rest[m] * areas[m] * by_angle
                jacobian[3 + m, 3 + m] += rest[m] * areas[m] * by_strain
