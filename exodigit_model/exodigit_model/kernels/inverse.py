r"""The inverse (pressures that hold given angles) and the robot-side estimator (§7, §12).

Both are exact for inextensible segments:

.. math::

    p = B_R^{-1}\bigl((J_R^*)^T f - \tau_s(q)\bigr), \quad f = (J_H^*)^{-T}\tau_H
    \quad\text{(inverse)}, \qquad
    f = (J_R^*)^{-T}\bigl(\tau_s(q) + B_R\,p\bigr) \quad\text{(estimator)}.

With extensible segments the bottom strains ε are unknown too. (12.4) gives p (inverse) or f
(estimator) for given ε exactly; substituted into (12.5) it leaves three equations in ε, solved
by Newton with their analytic Jacobian from ε = 0:

- inverse: g(ε) = S(ε, 0) − w ∘ R(ε, 0), w_k = ℓ̂_k A_p,k / (r_pA_p)_k (residuals at p = 0);
- estimator: h(ε) = S_free − ℓ̂ ∘ (J_ℓ*)ᵀ f with f = (J_R*)^{-T} R_free (the glove alone at the
  measured p), and (J_R*)ᵀ ∂f/∂ε_m = ∂R_free/∂ε_m − ℓ̂_m (∂J_R*/∂ℓ_m)ᵀ f.

An inextensible segment of a mixed glove keeps the equation ε_k = 0.
"""

from __future__ import annotations

import math

import numpy as np

from .constants import unpack
from .jit import kernel
from .kinematics import finger_terms, robot_jacobians, robot_terms
from .linear import solve, transpose_product, transpose_solve
from .newton import ARMIJO, MAX_HALVINGS, MAX_ITERATIONS, RTOL, XTOL, allowed, norm
from .solves import in_range_of_motion, stretch_in_range
from .statics import evaluate
from .structural import structural_torque
from .workspace import workspace


@kernel
def strain_balance(glove, work, q, strain, pressure, motion, estimating):
    """The three strain equations at ``strain`` (module docstring), their Jacobian and scale.

    Returns (value (3,), slope (3, 3), scale, other): ``other`` is p (Pa) for the inverse and
    f (N) for the estimator, at this ``strain``.
    """
    x = np.empty(6)
    x[:3] = q
    x[3:] = strain
    residual = np.empty(6)
    jacobian = np.empty((6, 6))
    forces = np.empty(3)
    torque = np.empty(3)
    value = np.empty(3)
    slope = np.empty((3, 3))
    other = np.empty(3)
    rest = glove.arc_lengths
    if not estimating:
        zero = np.zeros(3)
        scale = evaluate(
            glove, work, x, zero, np.bool_(False), motion, 0.0, residual, jacobian, forces, torque
        )
        for k in range(3):
            other[k] = -residual[k] / glove.pressure_moments[k]
            w = 0.0
            if glove.extensible_segments[k]:
                w = rest[k] * glove.pressure_areas[k] / glove.pressure_moments[k]
            value[k] = residual[3 + k] - w * residual[k]
            for m in range(3):
                slope[k, m] = jacobian[3 + k, 3 + m] - w * jacobian[k, 3 + m]
        return value, slope, scale, other
    scale = evaluate(
        glove, work, x, pressure, np.bool_(True), motion, 0.0, residual, jacobian, forces, torque
    )
    lengths = np.empty(3)
    for k in range(3):
        lengths[k] = rest[k] * (1.0 + strain[k])
    robot_terms(q, lengths, glove.block_half_lengths, np.bool_(True), work)
    j_robot, j_length = work.j_robot, work.j_length
    transpose_solve(j_robot, residual[:3], other)
    stretching = np.empty(3)
    transpose_product(j_length, other, stretching)
    rhs = np.empty(3)
    force_slope = np.empty(3)
    column = np.empty(3)
    for m in range(3):
        for k in range(3):
            rhs[k] = jacobian[k, 3 + m]
            for i in range(3):
                rhs[k] -= rest[m] * work.robot_length_slopes[m, i, k] * other[i]
        transpose_solve(j_robot, rhs, force_slope)
        transpose_product(j_length, force_slope, column)
        for k in range(3):
            slope[k, m] = jacobian[3 + k, 3 + m]
            if glove.extensible_segments[k]:
                slope[k, m] -= rest[k] * column[k]
    for k in range(3):
        if glove.extensible_segments[k]:
            value[k] = residual[3 + k] - rest[k] * stretching[k]
        else:
            value[k] = residual[3 + k]
    return value, slope, scale, other


STRAIN_STARTS = (0.0, 0.3, 0.6)
"""Bottom strains the strain balance starts from, in turn, on the extensible segments.

Between the unstretched layer and the root, the balance of a soft layer under a high pressure
and a stiff finger can have a local minimum above zero (g > 0, g' = 0): Newton from ε = 0
stalls there. The balance falls without bound as ε grows, so a start beyond the root converges;
the first start that converges gives the root returned (the one nearest the unstretched layer
when several exist)."""


@kernel
def balance_strains(glove, work, q, pressure, motion, estimating):
    """Newton on :func:`strain_balance`, from each of STRAIN_STARTS until one converges.

    Returns (converged, strain (3,), other (3,), value (3,)): ``other`` as in
    :func:`strain_balance`, ``value`` the balance left at ``strain`` (zero when converged).
    """
    strain = np.zeros(3)
    other = np.zeros(3)
    value = np.zeros(3)
    for start in STRAIN_STARTS:
        for k in range(3):
            strain[k] = start if glove.extensible_segments[k] else 0.0
        converged, other, value = newton_on_strains(
            glove, work, q, strain, pressure, motion, estimating
        )
        if converged:
            break
    return converged, strain, other, value


@kernel
def newton_on_strains(glove, work, q, strain, pressure, motion, estimating):
    """Damped Newton on :func:`strain_balance` from ``strain`` (updated in place).

    Returns (converged, other (3,), value (3,)) at the final ``strain``.
    """
    trial = np.empty(3)
    step = np.empty(3)
    x = np.empty(6)
    x[:3] = q
    value, slope, scale, other = strain_balance(
        glove, work, q, strain, pressure, motion, estimating
    )
    size = norm(value)
    outcome = (value, slope, scale, other)
    trial_size = size
    for _ in range(MAX_ITERATIONS):
        if size <= RTOL * scale:
            return True, other, value
        solve(slope, -value, step, work.matrix)
        step_size = norm(step)
        if not math.isfinite(step_size):
            return False, other, value
        alpha = 1.0
        accepted = False
        for _ in range(MAX_HALVINGS):
            for k in range(3):
                trial[k] = strain[k] + alpha * step[k]
                x[3 + k] = trial[k]
            if allowed(glove, x):
                outcome = strain_balance(glove, work, q, trial, pressure, motion, estimating)
                trial_size = norm(outcome[0])
                if math.isfinite(trial_size) and (
                    step_size <= XTOL or trial_size <= (1.0 - ARMIJO * alpha) * size
                ):
                    accepted = True
                    break
            alpha *= 0.5
        if not accepted:
            return False, other, value
        strain[:] = trial
        value, slope, scale, other = outcome
        size = trial_size
        if step_size <= XTOL:
            return True, other, value
    return size <= RTOL * scale, other, value


@kernel
def hold(packed, q, motion):
    """(converged, bottom strains, pressures (Pa), balance left) that hold angles ``q``.

    ``motion`` as in :func:`.statics.finger_load` (the speed row gives q̇; ``rate`` is 0).
    """
    glove, work = unpack(packed), workspace()
    finger = work.motion  # writable, as every kernel below is given it (read-only from Python)
    finger[:, :] = motion
    if glove.extensible:
        return balance_strains(glove, work, q, np.zeros(3), finger, np.bool_(False))
    x = q.copy()
    residual = np.empty(3)
    jacobian = np.empty((3, 3))
    forces = np.empty(3)
    torque = np.empty(3)
    vented, static = np.zeros(3), np.bool_(False)
    evaluate(glove, work, x, vented, static, finger, 0.0, residual, jacobian, forces, torque)
    pressure = np.empty(3)
    for k in range(3):
        pressure[k] = -residual[k] / glove.pressure_moments[k]
    return True, np.zeros(3), pressure, np.zeros(3)


@kernel(counted=False, forceinline=True)
def robot_side_forces(glove, work, q, pressure, forces):
    """Robot-side f = (J_R*)^{-T}(τ_s(q) + B_R p) (N), inextensible segments, into ``forces``.

    The residual of the glove alone (no finger) and J_R*, nothing else: the numbers
    :func:`.statics.evaluate` of the free glove and a transpose solve give, without the
    Jacobian that evaluation computes too.
    """
    moments, balance = glove.pressure_moments, work.rhs
    for k in range(3):
        tau, _ = structural_torque(glove, k, q[k])
        balance[k] = tau + moments[k] * pressure[k]
    robot_jacobians(q, glove.arc_lengths, glove.block_half_lengths, np.bool_(False), work)
    transpose_solve(work.j_robot, balance, forces)


@kernel(counted=False)
def estimate_into(glove, work, angles, pressures, forces):
    """:func:`robot_side_forces` for every row of angles and pressures (N, 3), into ``forces``.

    Counts no references: every view a row takes would cost an atomic count pair otherwise
    (:func:`.jit.kernel`), more than the estimate's arithmetic.
    """
    for r in range(angles.shape[0]):
        robot_side_forces(glove, work, angles[r], pressures[r], forces[r])


@kernel
def estimate(glove, work, q, pressure):
    """Robot-side contact forces (N) from measured ``q`` and ``pressure``, bottom strains.

    Returns (converged, strain (3,), forces (3,), balance left (3,)); needs no finger model.
    """
    if glove.extensible:
        return balance_strains(glove, work, q, pressure, np.zeros((3, 3)), np.bool_(True))
    forces = np.empty(3)
    robot_side_forces(glove, work, q, pressure, forces)
    return True, np.zeros(3), forces, np.zeros(3)


@kernel
def estimate_one(packed, q, pressure, valid_low, valid_high):
    """:func:`robot_side_forces` of one inextensible glove and its checks, in one call.

    Returns f (N), :func:`.solves.stretch_in_range` and :func:`.solves.in_range_of_motion` of
    the state. Inextensible segments only: an extensible glove's strains are balanced first
    (:func:`estimate_rows`), and linking that Newton solve in here too would cost seconds of
    compile for a call that is not on anyone's hot path.
    """
    glove, work = unpack(packed), workspace()
    forces = np.empty(3)
    robot_side_forces(glove, work, q, pressure, forces)
    valid = stretch_in_range(glove, q, valid_low, valid_high)
    return forces, valid, in_range_of_motion(glove, q)


@kernel
def estimate_rows(packed, angles, pressures):
    """:func:`estimate` for rows (N, 3): converged (N,), strains, forces, balance left (N, 3)."""
    glove, work = unpack(packed), workspace()
    rows = angles.shape[0]
    converged = np.empty(rows, np.bool_)
    strains = np.empty((rows, 3))
    forces = np.empty((rows, 3))
    left = np.empty((rows, 3))
    if not glove.extensible:  # the estimate in place, row by row: nothing allocated per row
        converged[:] = True
        strains[:] = 0.0
        left[:] = 0.0
        estimate_into(glove, work, angles, pressures, forces)
        return converged, strains, forces, left
    for r in range(rows):
        converged[r], strains[r], forces[r], left[r] = estimate(
            glove, work, angles[r], pressures[r]
        )
    return converged, strains, forces, left


@kernel
def contact_torques(packed, angles, forces):
    """(J_H*)ᵀ f per row of angles and contact forces (N, 3): the finger's joint torque, N·m."""
    glove, work = unpack(packed), workspace()
    torque = np.empty(angles.shape)
    for r in range(angles.shape[0]):
        finger_terms(angles[r], glove.finger_half_lengths, work.j_finger, work.finger_slopes)
        transpose_product(work.j_finger, forces[r], torque[r])
    return torque


@kernel
def robot_contact_torques(packed, angles, forces):
    """(J_R*)ᵀ f per row of angles and contact forces (N, 3): the exo-digit's joint torque, N·m.

    The robot-side twin of :func:`contact_torques`, at the segments' rest lengths.
    """
    glove, work = unpack(packed), workspace()
    torque = np.empty(angles.shape)
    for r in range(angles.shape[0]):
        robot_terms(angles[r], glove.arc_lengths, glove.block_half_lengths, np.bool_(False), work)
        transpose_product(work.j_robot, forces[r], torque[r])
    return torque
