r"""Extensible soft segments (MODEL.md §12): the coupled statics with the bottom-face stretch.

Each segment k has a second coordinate, the strain ε_k = λ_b,k − 1 of its bottom face (the
strain-limiting layer), so its arc length is ℓ_k = ℓ̂_k (1 + ε_k) in every chord of the
kinematics. With the resultants M, N of (12.2) (:class:`.section.SectionResultants`), the
layer's force E_L ε and the pressure area A_p of (12.3), virtual work gives per segment

.. math::

    R_k = -M_k + (r_pA_p)_k p_k - [(J_R^*)^T f]_k = 0 \qquad (12.4)

    S_k = \hat\ell_k \bigl(-N_k - E_{L,k} \varepsilon_k + A_{p,k} p_k
          - [(J_\ell^*)^T f]_k\bigr) = 0 \qquad (12.5)

with f = (J_H*)^{-T} τ_H(q) from the finger (it does not depend on ε). (12.5) is written as the
generalized force conjugate to ε (the factor ℓ̂_k = ∂ℓ_k/∂ε_k), so that all six residuals are
in N·m and one norm judges them. A segment with an inextensible layer (E_L = ∞) keeps ε_k = 0
by the row ε_k = 0. The unknowns are x = (q_1..3, ε_1..3); :class:`ExtensibleEvaluation` gives
the residual and its analytic 6×6 Jacobian (docstring of :meth:`~.kinematics.RobotJacobian
.length_terms` for the slopes of J_R* and J_ℓ*).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .coupling import MIN_TOP_STRETCH, AffineInPressure, transpose_product, transpose_solve
from .kinematics import chords, finger_jacobian, robot_jacobian


@dataclass(frozen=True)
class Layers:
    """The per-segment constants of (12.4)-(12.5) (SI).

    Attributes
    ----------
    rest_lengths : tuple
        ℓ̂_k, m.
    stiffness : tuple
        E_L,k, N (``inf``: inextensible).
    areas : tuple
        A_p,k of (12.3), m².
    extensible : tuple of bool
        Whether segment k's bottom face stretches.
    """

    rest_lengths: tuple
    stiffness: tuple
    areas: tuple
    extensible: tuple


def solve_linear(matrix, rhs):
    """X with A x = b for a nested n×n list A (floats, or 1-D arrays for a batch)."""
    a = np.array(matrix, dtype=float)
    b = np.array(rhs, dtype=float)
    if a.ndim == 2:
        return np.linalg.solve(a, b).tolist()
    # a batch: (n, n, N) -> (N, n, n); a singular row gives NaN there, not an exception.
    stacked, right = np.moveaxis(a, -1, 0), np.moveaxis(b, -1, 0)
    try:
        return list(np.linalg.solve(stacked, right[..., None])[..., 0].T)
    except np.linalg.LinAlgError:
        pass
    determinant = np.linalg.det(stacked)
    usable = np.isfinite(determinant) & (determinant != 0.0)
    solution = np.full(right.shape, np.nan)
    if usable.any():
        solution[usable] = np.linalg.solve(stacked[usable], right[usable][..., None])[..., 0]
    return list(solution.T)


class ExtensibleEvaluation(AffineInPressure):
    """(12.4)-(12.5) and the finger-side forces at one state (or a batch); ∂/∂x on request.

    Parameters
    ----------
    x : list of 6
        q_1..3 (rad) and ε_1..3 (bottom-face strains): floats, or 1-D arrays for a batch.
    ops : backend of :mod:`._backend`
    geometry : Geometry
    resultants : SectionResultants
    layers : Layers
    p : list of 3
        Pressures, Pa.
    load : callable, optional
        The finger of the solve (:class:`.patient.FingerLoad`); None for free motion.

    Attributes
    ----------
    residual : list of 6
        R_1..3 and S_1..3, N·m.
    scale : float or array
        Size of the terms the residuals are made of, N·m (what they are judged against).
    forces, finger_torque : list of 3
        f, N, and τ_H, N·m.
    lengths : list of 3
        ℓ_k = ℓ̂_k (1 + ε_k), m.
    """

    def __init__(self, x, ops, geometry, resultants, layers: Layers, p, load) -> None:
        self.x, self.q, self.pressure = x, x[:3], p
        self.geometry, self.layers, self.load = geometry, layers, load
        self._jacobian = None
        q, strain = x[:3], x[3:]
        self.lengths = [layers.rest_lengths[k] * (1.0 + strain[k]) for k in range(3)]
        columns = resultants.at(np.array(q, dtype=float).T, np.array(strain, dtype=float).T)
        self._m, self._n, self._mq, self._me, self._nq, self._ne = (
            np.asarray(c).tolist() if ops.single_state else list(np.asarray(c).T) for c in columns
        )
        self._robot = robot_jacobian(chords(q, ops), self.lengths, geometry.block_half_lengths)
        self._lengthwise = self._robot.length_terms(self.lengths)
        zero = 0.0 * q[0]
        if load is None:
            self.finger_torque = self.forces = [zero, zero, zero]
            self._coupling = self._stretching = [zero, zero, zero]
        else:
            self._finger, self._finger_slopes = finger_jacobian(
                q, ops, geometry.finger_half_lengths
            )
            self.finger_torque, self._load_slopes = load(q)
            self.forces = transpose_solve(self._finger, self.finger_torque)
            self._coupling = transpose_product(self._robot.matrix, self.forces)
            self._stretching = transpose_product(self._lengthwise[0], self.forces)
        self._set_pressure(p)

    def _set_pressure(self, p) -> None:
        moments, layers = self.geometry.pressure_moments, self.layers
        strain = self.x[3:]
        rows, sizes = [], []
        for k in range(3):
            drive = moments[k] * p[k]
            rows.append(-self._m[k] + drive - self._coupling[k])
            sizes.append(abs(self._m[k]) + abs(drive) + abs(self._coupling[k]))
        for k in range(3):
            if layers.extensible[k]:
                length = layers.rest_lengths[k]
                layer = layers.stiffness[k] * strain[k]
                area = layers.areas[k] * p[k]
                rows.append(length * (-self._n[k] - layer + area - self._stretching[k]))
                sizes.append(
                    length * (abs(self._n[k]) + abs(layer) + abs(area) + abs(self._stretching[k]))
                )
            else:
                rows.append(strain[k] + 0.0)
                sizes.append(0.0 * strain[k])
        self.residual = rows
        self.scale = sum(size * size for size in sizes) ** 0.5

    def _compute_jacobian(self) -> list:
        """∂(R, S)/∂(q, ε), nested 6×6 list, N·m per rad (or per unit strain)."""
        zero = 0.0 * self.q[0]
        jacobian = [[zero] * 6 for _ in range(6)]
        layers, rest = self.layers, self.layers.rest_lengths
        forces = self.forces
        # force slopes ∂f/∂q_m (the finger side depends on q only)
        if self.load is None:
            force_slopes = [[zero, zero, zero] for _ in range(3)]
        else:
            force_slopes = []
            for m in range(3):
                rhs = [self._load_slopes[k] if k == m else 0.0 for k in range(3)]
                for i, k, slope in self._finger_slopes[m]:
                    rhs[k] = rhs[k] - slope * forces[i]
                force_slopes.append(transpose_solve(self._finger, rhs))
        length_matrix, length_slopes, robot_length_slopes = self._lengthwise
        robot_slopes = self._robot.slopes()
        for m in range(3):
            column_r = [-c for c in transpose_product(self._robot.matrix, force_slopes[m])]
            for i, k, slope in robot_slopes[m]:
                column_r[k] = column_r[k] - slope * forces[i]
            column_r[m] = column_r[m] - self._mq[m]
            column_s = [-c for c in transpose_product(length_matrix, force_slopes[m])]
            for i, k, slope in length_slopes[m]:
                column_s[k] = column_s[k] - slope * forces[i]
            column_s[m] = column_s[m] - self._nq[m]
            for k in range(3):
                jacobian[k][m] = column_r[k]
                if layers.extensible[k]:
                    jacobian[3 + k][m] = rest[k] * column_s[k]
        for m in range(3):  # ε_m: through ℓ_m = ℓ̂_m (1 + ε_m) and the resultants
            column_r = [zero, zero, zero]
            for i, k, slope in robot_length_slopes[m]:
                column_r[k] = column_r[k] - rest[m] * slope * forces[i]
            column_r[m] = column_r[m] - self._me[m]
            for k in range(3):
                jacobian[k][3 + m] = column_r[k]
            if layers.extensible[m]:
                jacobian[3 + m][3 + m] = -rest[m] * (self._ne[m] + layers.stiffness[m])
            else:
                jacobian[3 + m][3 + m] = 1.0 + zero
        return jacobian


def allowed_stretch(x, strain_per_angle):
    """Whether a trial keeps the bottom face and the top fibre above MIN_TOP_STRETCH (12.1)."""
    ok = True
    for k in range(3):
        bottom = 1.0 + x[3 + k]
        top = bottom + x[k] * strain_per_angle[k]
        ok = ok & (bottom >= MIN_TOP_STRETCH) & (top >= MIN_TOP_STRETCH)
    return ok
