r"""Coupled quasi-statics of exo-digit and finger (eqs 31, 34-36, MODEL.md §6-7, §11).

With f the contact forces (robot on finger, positive towards flexion) and τ_H the joint torque
the finger needs (:mod:`.patient`, eq 11.1; the paper's K_H q),

.. math::

    \tau_H = (J_H^*)^T f \quad (34), \qquad
    F(q, p) = \tau_s(q) + B_R\,p - (J_R^*)^T f = 0 \quad (35)

and eliminating f = (J_H^*)^{-T} τ_H gives eq 36 (11.4). :class:`Evaluation` holds F and the
finger-side forces at a state and computes the analytic Jacobian ∂F/∂q on request:

.. math::

    \frac{\partial F_k}{\partial q_m} = \delta_{km}\tau_{s,k}'(q_k)
      - \sum_i \frac{\partial J^*_{R,ik}}{\partial q_m} f_i - \sum_i J^*_{R,ik}
      \frac{\partial f_i}{\partial q_m}, \qquad
    (J_H^*)^T\frac{\partial f}{\partial q_m} = \frac{\partial \tau_{H,m}}{\partial q_m} e_m
      - \Bigl(\frac{\partial J_H^*}{\partial q_m}\Bigr)^T f.

Everything works on per-joint lists of floats or of 1-D arrays (see :mod:`._backend`).
"""

from __future__ import annotations

import copy
from dataclasses import dataclass

from .kinematics import chords, finger_jacobian, robot_jacobian


@dataclass(frozen=True)
class Geometry:
    """The numbers the coupled equations need, as plain floats (SI).

    Attributes
    ----------
    arc_lengths : tuple
        ℓ̂_k of the three soft segments, m.
    block_half_lengths : tuple
        d_0..d_3 of the base block and the three blocks, m.
    finger_half_lengths : tuple
        ℓ_1, ℓ_2, ℓ_3: half lengths of the finger links, m.
    pressure_moments : tuple
        (r_p A_p)_k of eq 12, m³ (the diagonal of B_R).
    """

    arc_lengths: tuple
    block_half_lengths: tuple
    finger_half_lengths: tuple
    pressure_moments: tuple


def transpose_solve(lower, rhs):
    """X with Lᵀ x = rhs for a lower-triangular 3x3 L (back substitution)."""
    x2 = rhs[2] / lower[2][2]
    x1 = (rhs[1] - lower[2][1] * x2) / lower[1][1]
    x0 = (rhs[0] - lower[1][0] * x1 - lower[2][0] * x2) / lower[0][0]
    return [x0, x1, x2]


def transpose_product(lower, v):
    """Lᵀ v for a lower-triangular 3x3 L."""
    return [
        lower[0][0] * v[0] + lower[1][0] * v[1] + lower[2][0] * v[2],
        lower[1][1] * v[1] + lower[2][1] * v[2],
        lower[2][2] * v[2],
    ]


def solve3(a, b):
    """X with A x = b for a general 3x3 A, by cofactors (works element-wise on arrays)."""
    c00 = a[1][1] * a[2][2] - a[1][2] * a[2][1]
    c01 = a[1][2] * a[2][0] - a[1][0] * a[2][2]
    c02 = a[1][0] * a[2][1] - a[1][1] * a[2][0]
    inv_det = 1.0 / (a[0][0] * c00 + a[0][1] * c01 + a[0][2] * c02)
    c10 = a[0][2] * a[2][1] - a[0][1] * a[2][2]
    c11 = a[0][0] * a[2][2] - a[0][2] * a[2][0]
    c12 = a[0][1] * a[2][0] - a[0][0] * a[2][1]
    c20 = a[0][1] * a[1][2] - a[0][2] * a[1][1]
    c21 = a[0][2] * a[1][0] - a[0][0] * a[1][2]
    c22 = a[0][0] * a[1][1] - a[0][1] * a[1][0]
    return [
        (c00 * b[0] + c10 * b[1] + c20 * b[2]) * inv_det,
        (c01 * b[0] + c11 * b[1] + c21 * b[2]) * inv_det,
        (c02 * b[0] + c12 * b[1] + c22 * b[2]) * inv_det,
    ]


class AffineInPressure:
    """The statics at one state, affine in the pressures (base of the two evaluations).

    :class:`Evaluation` and :class:`.extensible.ExtensibleEvaluation` share it. Their residuals
    are affine in p with coefficients that do not depend on p (eq 36, (12.4)-(12.5)), so the
    same state under other pressures costs only the pressure terms, and the Jacobian, which
    does not depend on p, is computed once and shared. A subclass sets ``pressure`` and
    ``_jacobian = None`` and defines ``_set_pressure(p)`` (the residual and its scale at p) and
    ``_compute_jacobian()``.
    """

    def at_pressure(self, p):
        """The same state under pressures ``p`` (exactly: the residual is affine in p)."""
        repriced = copy.copy(self)
        repriced.pressure = p
        repriced._set_pressure(p)
        return repriced

    def jacobian(self) -> list:
        """∂residual/∂unknowns, a nested square list, analytic; computed once, then shared."""
        if self._jacobian is None:
            self._jacobian = self._compute_jacobian()
        return self._jacobian


class Evaluation(AffineInPressure):
    """F(q, p) and the finger-side forces at one state (or a batch); ∂F/∂q on request.

    Parameters
    ----------
    q, p : list of 3
        The state, rad, and the pressures, Pa (floats, or 1-D arrays for a batch).
    ops : backend of :mod:`._backend`
    geometry : Geometry
    structural_joints : tuple of 3 callables
        q_k -> (τ_s,k, dτ_s,k/dq_k).
    load : callable, optional
        q -> (τ_H, ∂τ_H/∂q per joint), the finger of this solve (:class:`.patient.FingerLoad`);
        None for free motion (no finger, f = 0).

    Attributes
    ----------
    residual : list of 3
        F(q, p) of eq 36 (11.4), N·m.
    scale : float or array
        Size of the terms F is made of, ‖|τ_s| + |B_R p| + |(J_R*)ᵀ f|‖, N·m: what the residual
        is judged against.
    forces : list of 3
        f = (J_H*)^{-T} τ_H, N.
    finger_torque : list of 3
        τ_H, N·m.
    """

    def __init__(self, q, ops, geometry: Geometry, structural_joints: tuple, p, load) -> None:
        self.q, self.pressure, self.geometry, self.load = q, p, geometry, load
        self._jacobian = None
        self._free = load is None
        torques = [structural_joints[k](q[k]) for k in range(3)]
        self._torques = [torques[k][0] for k in range(3)]
        self._torque_slopes = [torques[k][1] for k in range(3)]
        if self._free:
            zero = 0.0 * q[0]
            self.finger_torque = self.forces = self._coupling = [zero, zero, zero]
        else:
            self._robot = robot_jacobian(
                chords(q, ops), geometry.arc_lengths, geometry.block_half_lengths
            )
            self._finger, self._finger_slopes = finger_jacobian(
                q, ops, geometry.finger_half_lengths
            )
            self.finger_torque, self._load_slopes = load(q)
            self.forces = transpose_solve(self._finger, self.finger_torque)
            self._coupling = transpose_product(self._robot.matrix, self.forces)
        self._set_pressure(p)

    @property
    def x(self) -> list:
        """The unknowns: the joint angles q."""
        return self.q

    def _set_pressure(self, p) -> None:
        moments, torques, coupling = self.geometry.pressure_moments, self._torques, self._coupling
        drive = [moments[k] * p[k] for k in range(3)]
        self.residual = [torques[k] + drive[k] - coupling[k] for k in range(3)]
        sizes = [abs(torques[k]) + abs(drive[k]) + abs(coupling[k]) for k in range(3)]
        self.scale = (sizes[0] * sizes[0] + sizes[1] * sizes[1] + sizes[2] * sizes[2]) ** 0.5

    def _compute_jacobian(self) -> list:
        """∂F/∂q (nested 3x3 list, N·m/rad), analytic (module docstring)."""
        zero = 0.0 * self.q[0]
        jacobian = [[zero, zero, zero], [zero, zero, zero], [zero, zero, zero]]
        if self._free:
            for k in range(3):
                jacobian[k][k] = self._torque_slopes[k]
            return jacobian
        robot_slopes = self._robot.slopes()
        j_robot, j_finger, forces = self._robot.matrix, self._finger, self.forces
        load_slopes = self._load_slopes
        for m in range(3):
            rhs = [load_slopes[k] if k == m else 0.0 for k in range(3)]
            for i, k, slope in self._finger_slopes[m]:
                rhs[k] = rhs[k] - slope * forces[i]
            column = [-c for c in transpose_product(j_robot, transpose_solve(j_finger, rhs))]
            for i, k, slope in robot_slopes[m]:
                column[k] = column[k] - slope * forces[i]
            column[m] = column[m] + self._torque_slopes[m]
            for k in range(3):
                jacobian[k][m] = column[k]
        return jacobian


def contact_jacobians(q, ops, geometry: Geometry) -> tuple[list, list]:
    """(J_R*, J_H*) as nested 3x3 lists of floats or arrays (MODEL.md §3)."""
    robot = robot_jacobian(chords(q, ops), geometry.arc_lengths, geometry.block_half_lengths)
    finger, _ = finger_jacobian(q, ops, geometry.finger_half_lengths)
    return robot.matrix, finger


MIN_TOP_STRETCH = 0.2
"""Lowest top-fibre stretch a trial state may have (the material law's domain, with margin)."""


def allowed_bending(q, strain_per_angle):
    """Whether trial angles keep every top fibre's stretch 1 + q H/ℓ̂ above MIN_TOP_STRETCH."""
    floor = MIN_TOP_STRETCH - 1.0
    return (
        (q[0] * strain_per_angle[0] >= floor)
        & (q[1] * strain_per_angle[1] >= floor)
        & (q[2] * strain_per_angle[2] >= floor)
    )
