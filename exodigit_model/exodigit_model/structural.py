r"""Structural (resisting) torque τ_s(q) of the three segments, fast and exact to 1e-12.

τ_s,i(q) = -M_i(q) with M_i the section integral of :mod:`.section` (eqs 13, 27). The solver
needs τ_s and dτ_s/dq thousands of times a second, so each joint's moment is tabulated once,
at construction, as a piecewise polynomial of

.. math:: G_i(u) = M_i(q) / q, \qquad u = q\,H_i / \hat\ell_i

where H_i is the section height, so u is the strain of the top fibre (λ_top = 1 + u). Dividing
by q keeps the *relative* error of M bounded as q → 0 (M is odd-like with M(0) = 0), and G is
smooth there. The table spans λ_top ∈ [1 + U_MIN, 1 + U_MAX] = [0.4, 2.6], far wider than the
validated range 1 ≤ λ ≤ 1.5; each piece is the Chebyshev interpolant of degree ``DEGREE`` at
first-kind nodes (which never fall on q = 0). Outside the table the moment is computed by
quadrature directly: slower, equally exact.
"""

from __future__ import annotations

import numpy as np
from numpy.polynomial import chebyshev
from numpy.typing import ArrayLike, NDArray

from .params import Material, Segment
from .section import SectionQuadrature, resisting_moment

U_MIN = -0.6
"""Lowest tabulated top-fibre strain (λ_top = 0.4)."""
U_MAX = 1.6
"""Highest tabulated top-fibre strain (λ_top = 2.6)."""
PIECES = 44
"""Number of equal pieces of the table in u."""
DEGREE = 9
"""Polynomial degree of each piece."""


def _piece_coefficients(values: NDArray) -> NDArray:
    """Monomial coefficients in t ∈ [-1, 1] of the Chebyshev interpolant through ``values``."""
    monomial = chebyshev.cheb2poly(chebyshev.chebfit(_NODES, values, DEGREE))
    return np.pad(monomial, (0, DEGREE + 1 - monomial.size))


_NODES = np.cos(np.pi * (np.arange(DEGREE + 1) + 0.5) / (DEGREE + 1))


class _JointTable:
    """G(u) of one joint as per-degree coefficient rows over the pieces (list and array)."""

    def __init__(self, material: Material, segment: Segment, rule: SectionQuadrature) -> None:
        self.material, self.segment, self.rule = material, segment, rule
        self.u_per_q = segment.height / segment.arc_length
        self.width = (U_MAX - U_MIN) / PIECES
        self.slope_scale = 2.0 * self.u_per_q / self.width  # dt/dq
        centres = U_MIN + self.width * (np.arange(PIECES) + 0.5)
        u = centres[:, None] + 0.5 * self.width * _NODES[None, :]
        q = u / self.u_per_q
        moment, _ = resisting_moment(material, segment, q, rule)
        coefficients = np.array([_piece_coefficients(row) for row in moment / q])
        # Per-degree rows: value rows[n][piece] multiplies t**n.
        self.value_rows = coefficients.T.copy()
        self.value_lists = self.value_rows.tolist()

    def torque_scalar(self, q: float) -> tuple[float, float]:
        """τ_s = -M(q) and dτ_s/dq for one float angle."""
        s = (q * self.u_per_q - U_MIN) / self.width
        if not 0.0 <= s < PIECES:
            moment, slope = resisting_moment(self.material, self.segment, q, self.rule)
            return -float(moment), -float(slope)
        piece = int(s)
        g, dg = _horner(self.value_lists, piece, 2.0 * (s - piece) - 1.0)
        return -q * g, -g - q * dg * self.slope_scale

    def torque_array(self, q: NDArray) -> tuple[NDArray, NDArray]:
        """τ_s = -M(q) and dτ_s/dq for a 1-D array of angles."""
        moment, slope = self._moment_array(q)
        return -moment, -slope

    def _moment_array(self, q: NDArray) -> tuple[NDArray, NDArray]:
        s = (q * self.u_per_q - U_MIN) / self.width
        inside = (s >= 0.0) & (s < PIECES)
        piece = np.where(inside, s, 0.0).astype(np.intp)
        t = 2.0 * (np.where(inside, s, 0.5) - piece) - 1.0
        g, dg = _horner(self.value_rows, piece, t)
        moment = q * g
        slope = g + q * dg * self.slope_scale
        if not inside.all():
            outside = ~inside
            moment[outside], slope[outside] = resisting_moment(
                self.material, self.segment, q[outside], self.rule
            )
        return moment, slope


def _horner(rows, piece, t):
    """G(t) and dG/dt of the polynomial piece(s) ``piece`` at ``t`` (float or array)."""
    g = rows[DEGREE][piece]
    dg = 0.0 * g
    for n in range(DEGREE - 1, -1, -1):
        dg = dg * t + g
        g = g * t + rows[n][piece]
    return g, dg


class StructuralTorque:
    """τ_s(q) and its derivative for the three segments of one material (eq 13, MODEL.md §5).

    Parameters
    ----------
    material : Material
    segments : sequence of Segment
        The three segments, in joint order.
    """

    def __init__(self, material: Material, segments: tuple[Segment, ...]) -> None:
        self.rules = tuple(SectionQuadrature.of(segment) for segment in segments)
        tables = [
            _JointTable(material, segment, rule)
            for segment, rule in zip(segments, self.rules, strict=True)
        ]
        self.scalar_joints = tuple(table.torque_scalar for table in tables)
        """Per joint: ``q_k -> (τ_s, dτ_s/dq)`` for a float angle (the solver's hot path)."""
        self.array_joints = tuple(table.torque_array for table in tables)
        """Per joint: ``q_k -> (τ_s, dτ_s/dq)`` for a 1-D array of angles."""

    def torque(self, q: ArrayLike) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """τ_s (N·m) and dτ_s/dq (N·m/rad) for angles of shape (3,) or (N, 3).

        Any other shape is a ValueError (``GloveModel.structural_torque`` names its argument).
        """
        angles = np.asarray(q, dtype=float)
        if angles.shape == (3,):
            angle_list = angles.tolist()
            pairs = [joint(a) for joint, a in zip(self.scalar_joints, angle_list, strict=True)]
            return np.array([t for t, _ in pairs]), np.array([s for _, s in pairs])
        if angles.ndim != 2 or angles.shape[1] != 3:
            raise ValueError(f'angles must have shape (3,) or (N, 3), got {angles.shape}')
        torque = np.empty_like(angles)
        slope = np.empty_like(angles)
        for joint in range(3):
            torque[:, joint], slope[:, joint] = self.array_joints[joint](angles[:, joint])
        return torque, slope
