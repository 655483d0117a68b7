r"""The τ_s tables of the three segments, built once per glove (eqs 13, 27; docs/spec/model.md §5).

τ_s,i(q) = −M_i(q) with M_i the section integral of :mod:`.kernels.section`. The solver needs
τ_s and dτ_s/dq thousands of times a second, so each joint's moment is tabulated as a piecewise
polynomial of

.. math:: G_i(u) = M_i(q) / q, \qquad u = q\,H_i / \hat\ell_i

where H_i is the section height, so u is the strain of the top fibre (λ_top = 1 + u). Dividing
by q keeps the *relative* error of M bounded as q → 0 (M is odd-like with M(0) = 0), and G is
smooth there. The table spans λ_top ∈ [1 + U_MIN, 1 + U_MAX] = [0.4, 2.6], far wider than the
validated range; each piece is the Chebyshev interpolant of degree ``DEGREE`` at first-kind
nodes (which never fall on q = 0), stored as monomial coefficients in t ∈ [−1, 1]. The kernel
:func:`.kernels.structural.structural_torque` evaluates it (and falls back on the quadrature
outside the table).
"""

from __future__ import annotations

import numpy as np
from numpy.polynomial import chebyshev
from numpy.typing import NDArray

from ..kernels.constants import DEGREE, PIECE_WIDTH, PIECES, U_MIN, GloveConstants
from ..kernels.section import resisting_moments

_NODES = np.cos(np.pi * (np.arange(DEGREE + 1) + 0.5) / (DEGREE + 1))


def _piece_coefficients(values: NDArray) -> NDArray:
    """Monomial coefficients in t ∈ [-1, 1] of the Chebyshev interpolant through ``values``."""
    monomial = chebyshev.cheb2poly(chebyshev.chebfit(_NODES, values, DEGREE))
    return np.pad(monomial, (0, DEGREE + 1 - monomial.size))


_TO_MONOMIAL = np.array([_piece_coefficients(unit) for unit in np.eye(DEGREE + 1)]).T
"""The interpolation is linear in the values at the nodes: this matrix maps them to the monomial
coefficients (column j is :func:`_piece_coefficients` of the j-th unit vector). One matrix product
per joint instead of a ``chebfit`` per piece: a glove's tables took about 24 ms, 60 times longer,
and the calibration builds them at every evaluation of its misfit."""


def torque_tables(glove: GloveConstants) -> NDArray[np.float64]:
    """The τ_s tables of ``glove`` (whose own ``table`` is not read), (3, DEGREE + 1, PIECES).

    ``[k, n, piece]`` multiplies tⁿ in G_k on ``piece``.
    """
    centres = U_MIN + PIECE_WIDTH * (np.arange(PIECES) + 0.5)
    u = centres[:, None] + 0.5 * PIECE_WIDTH * _NODES[None, :]
    tables = np.empty((3, DEGREE + 1, PIECES))
    for k in range(3):
        q = u / glove.strain_per_angle[k]
        moment, _ = resisting_moments(glove, k, q.ravel())
        g = moment.reshape(q.shape) / q
        tables[k] = _TO_MONOMIAL @ g.T
    return tables
