r"""τ_s(q) of one segment from its table: fast and exact to 1e-12 (eqs 13, 27).

The moment M(q) is tabulated once per glove (:class:`..structural.StructuralTorque` builds the
table) as a piecewise polynomial of

.. math:: G(u) = M(q) / q, \qquad u = q\,H / \hat\ell

(u is the top fibre's strain), ``PIECES`` equal pieces over [U_MIN, U_MAX], each a polynomial of
degree ``DEGREE`` in t ∈ [−1, 1]. Outside the table the quadrature of :mod:`.section` answers:
slower, equally exact.
"""

from __future__ import annotations

import numpy as np

from .constants import DEGREE, PIECE_WIDTH, PIECES, U_MIN, unpack
from .jit import kernel
from .section import resultants


@kernel(counted=False, forceinline=True)
def structural_torque(glove, k, q):
    """τ_s = −M(q) (N·m) and dτ_s/dq (N·m/rad) of segment ``k`` at angle ``q`` (rad)."""
    u_per_q = glove.strain_per_angle[k]
    s = (q * u_per_q - U_MIN) / PIECE_WIDTH
    if not 0.0 <= s < PIECES:
        moment, _, moment_slope, _, _ = resultants(glove, k, q, 0.0)
        return -moment, -moment_slope
    piece = int(s)
    t = 2.0 * (s - piece) - 1.0
    table = glove.table
    g = table[k, DEGREE, piece]
    dg = 0.0
    for n in range(DEGREE - 1, -1, -1):
        dg = dg * t + g
        g = g * t + table[k, n, piece]
    return -q * g, -g - q * dg * (2.0 * u_per_q / PIECE_WIDTH)


@kernel
def structural_torques(packed, angles):
    """τ_s (N·m) and dτ_s/dq (N·m/rad) for rows of angles (N, 3), rad (``packed`` constants)."""
    glove = unpack(packed)
    torque = np.empty(angles.shape)
    slope = np.empty(angles.shape)
    for r in range(angles.shape[0]):
        for k in range(3):
            torque[r, k], slope[r, k] = structural_torque(glove, k, angles[r, k])
    return torque, slope
