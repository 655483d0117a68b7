r"""Planar kinematics of the exo-digit and the finger and their contact Jacobians (§2-3, §12).

Points of the plane are complex numbers z = x + iy; a rotation by a is a product with e^{ia}.
Joint order MCP, PIP, DIP (index 0, 1, 2); φ_j = q_0 + … + q_{j−1} orients body j (φ_0 = 0).

**Exo-digit** (eqs 1-4, y-row of eq 4 corrected, docs/spec/model.md §9). An arc of length ℓ bent
by q has the chord ℓ·C(q) with

.. math:: C(q) = \frac{e^{iq} - 1}{iq} = \frac{\sin(q/2)}{q/2}\,e^{iq/2}

(x = ℓ sin q / q, y = ℓ (1 − cos q)/q, smooth at q = 0 in the sinc form), so body k+1 starts
at z_{k+1} = z_k + e^{iφ_k}(2 d_k + ℓ_k C(q_k)) and its centre is
zc_k = z_{k+1} + e^{iφ_{k+1}} d_{k+1}.

**Contact Jacobians** (§3). Contact i pushes along n_i = i e^{iφ_{i+1}} at zc_i, so
J*[i, k] = n_i · ∂zc_i/∂q_k. With D_ik = ∂zc_i/∂q_k = i(zc_i − z_{k+1}) + e^{iφ_k} ℓ_k C'(q_k)
(k ≤ i) and A_ik = e^{−iφ_{i+1}} D_ik,

.. math:: J^*_{R,ik} = \operatorname{Im} A_{ik}, \qquad
          \frac{\partial J^*_{R,ik}}{\partial q_m} = \begin{cases}
          \operatorname{Re}(A_{im} - A_{ik}) & k < m \le i \\
          -\operatorname{Re} A_{ik} + \operatorname{Im}\bigl(e^{-i\varphi_{i+1}}
          (e^{i\varphi_k}\ell_k C''(q_k) - (zc_i - z_{k+1}))\bigr) & m = k \\
          0 & \text{otherwise.} \end{cases}

**Extensible segments** (§12). With B_ik = e^{i(φ_k − φ_{i+1})} C(q_k),
∂zc_i/∂ℓ_k = e^{iφ_k} C(q_k) (k ≤ i), so J*_ℓ,ik = Im B_ik (it does not depend on ℓ),
∂J*_ℓ,ik/∂q_m = −Re B_ik + [m = k] Im(e^{i(φ_k − φ_{i+1})} C'(q_k)) (k ≤ m ≤ i),
∂J*_R,im/∂ℓ_k = Re B_ik (m < k ≤ i) and ∂J*_R,ik/∂ℓ_k = Im(e^{i(φ_k − φ_{i+1})} C'(q_k)).

**Finger** (eqs 32-34): hinges, link k of length 2ℓ_k with its contact at ℓ_k from joint k:
J*_H[i, k] = ℓ_i + Σ_{j=k}^{i−1} 2ℓ_j cos(q_{j+1} + … + q_i), the paper's printed (J_H*)ᵀ.

Both Jacobians are lower triangular with positive diagonals (d_{k+1} + ℓ_k(1 − cos q_k)/q_k²
and ℓ_k): always invertible. Slopes are arrays ``[m, i, k]`` = ∂J[i, k]/∂q_m. The kernels
fill arrays of a :class:`.workspace.Workspace` (or given ones) in place.
"""

from __future__ import annotations

import math

import numpy as np

from .jit import kernel

SERIES_LIMIT = 0.25
"""Below this half-angle, sinc and its derivatives come from their Taylor series."""


@kernel(counted=False, forceinline=True)
def sinc_terms(x):
    """s(x) = sin(x)/x, s'(x) and s''(x), smooth and accurate at x = 0.

    The closed forms cancel catastrophically for small |x|, where the Taylor series in x²
    (coefficients (−1)ⁿ/(2n+1)!, error below 1e-17 for |x| < SERIES_LIMIT) is used.
    """
    if abs(x) < SERIES_LIMIT:
        a1, a2, a3 = -1.0 / 6.0, 1.0 / 120.0, -1.0 / 5040.0
        a4, a5 = 1.0 / 362880.0, -1.0 / 39916800.0
        x2 = x * x
        s = 1.0 + x2 * (a1 + x2 * (a2 + x2 * (a3 + x2 * (a4 + x2 * a5))))
        s1 = x * (2 * a1 + x2 * (4 * a2 + x2 * (6 * a3 + x2 * (8 * a4 + x2 * 10 * a5))))
        s2 = 2 * a1 + x2 * (12 * a2 + x2 * (30 * a3 + x2 * (56 * a4 + x2 * 90 * a5)))
        return s, s1, s2
    s = math.sin(x) / x
    s1 = (math.cos(x) - s) / x
    return s, s1, -s - 2.0 * s1 / x


@kernel(counted=False, forceinline=True)
def chord_terms(q, half_turn, chord, slope, curvature):
    """Per joint, into the complex arrays (3,): e^{iq/2}, the unit chord C(q), C'(q), C''(q)."""
    for k in range(3):
        x = 0.5 * q[k]
        s, s1, s2 = sinc_terms(x)
        h = complex(math.cos(x), math.sin(x))
        half_turn[k] = h
        chord[k] = s * h
        slope[k] = 0.5 * h * complex(s1, s)
        curvature[k] = 0.25 * h * complex(s2 - s, 2.0 * s1)


@kernel(counted=False, forceinline=True)
def frames(half_turn, chord, lengths, half_lengths, turns, origins, centres):
    """Into ``turns`` e^{iφ_j} (4), body origins z_j (4) and contact points zc_k (3) (eq 4).

    ``lengths`` are the arcs' bottom-face lengths ℓ_k, ``half_lengths`` d_0..d_3 (m).
    """
    turns[0] = 1.0
    origins[0] = 0.0
    for k in range(3):
        origins[k + 1] = origins[k] + turns[k] * (2.0 * half_lengths[k] + lengths[k] * chord[k])
        turns[k + 1] = turns[k] * half_turn[k] * half_turn[k]
        centres[k] = origins[k + 1] + turns[k + 1] * half_lengths[k + 1]


@kernel(counted=False)
def robot_terms(q, lengths, half_lengths, with_lengths, work):
    """J_R* and its slopes into ``work`` (:class:`.workspace.Workspace`).

    With ``with_lengths`` also J_ℓ* and the slopes §12 adds (``j_length``, ``length_slopes``,
    ``robot_length_slopes``; left as they are otherwise). :func:`robot_jacobians`, then
    :func:`robot_slopes_of`.
    """
    robot_jacobians(q, lengths, half_lengths, with_lengths, work)
    robot_slopes_of(lengths, work)


@kernel(counted=False, forceinline=True)
def robot_jacobians(q, lengths, half_lengths, with_lengths, work):
    """J_R* into ``work``, and with ``with_lengths`` J_ℓ* and its slopes: no slope of J_R*.

    What a residual needs (:func:`.statics.residual_of`); :func:`robot_slopes_of` adds the
    slopes of J_R* from the frames this leaves in ``work``.
    """
    chord, slope, curvature = work.chord, work.chord_slope, work.curvature
    turns, origins, centres, local = work.turns, work.origins, work.centres, work.local
    chord_terms(q, work.half_turn, chord, slope, curvature)
    frames(work.half_turn, chord, lengths, half_lengths, turns, origins, centres)
    j_robot = work.j_robot
    j_length, length_slopes, robot_length_slopes = (
        work.j_length,
        work.length_slopes,
        work.robot_length_slopes,
    )
    j_robot[:, :] = 0.0
    if with_lengths:
        j_length[:, :] = 0.0
        length_slopes[:, :, :] = 0.0
        robot_length_slopes[:, :, :] = 0.0
    for i in range(3):
        back = turns[i + 1].conjugate()
        for k in range(i + 1):
            relative = back * (centres[i] - origins[k + 1])
            unit_turn = back * turns[k]
            turn = unit_turn * lengths[k]
            a = 1j * relative + turn * slope[k]
            local[i, k] = a
            j_robot[i, k] = a.imag
            if with_lengths:
                b = unit_turn * chord[k]
                b_slope = (unit_turn * slope[k]).imag
                j_length[i, k] = b.imag
                length_slopes[k, i, k] = b_slope - b.real
                robot_length_slopes[k, i, k] = b_slope
                for m in range(k + 1, i + 1):
                    length_slopes[m, i, k] = -b.real
                for m in range(k):
                    robot_length_slopes[k, i, m] = b.real


@kernel(counted=False, forceinline=True)
def robot_slopes_of(lengths, work):
    """The slopes of J_R* into ``work.robot_slopes``, from the frames of :func:`robot_jacobians`.

    ``lengths`` must be the ones that call was given.
    """
    turns, origins, centres, local = work.turns, work.origins, work.centres, work.local
    curvature, robot_slopes = work.curvature, work.robot_slopes
    robot_slopes[:, :, :] = 0.0
    for i in range(3):
        back = turns[i + 1].conjugate()
        for k in range(i + 1):
            relative = back * (centres[i] - origins[k + 1])
            turn = back * turns[k] * lengths[k]
            robot_slopes[k, i, k] = (turn * curvature[k] - relative).imag - local[i, k].real
    for i in range(3):
        for k in range(i + 1):
            for m in range(k + 1, i + 1):
                robot_slopes[m, i, k] = (local[i, m] - local[i, k]).real


@kernel(counted=False, forceinline=True)
def finger_terms(q, half_lengths, matrix, slopes):
    """J_H*[i, k] of the finger into ``matrix`` (3, 3), its slopes [m, i, k] into ``slopes``."""
    l0, l1, l2 = half_lengths[0], half_lengths[1], half_lengths[2]
    c1, s1 = math.cos(q[1]), math.sin(q[1])
    c2, s2 = math.cos(q[2]), math.sin(q[2])
    q12 = q[1] + q[2]
    c12, s12 = math.cos(q12), math.sin(q12)
    row2 = l2 + 2.0 * l1 * c2
    matrix[:, :] = 0.0
    matrix[0, 0] = l0
    matrix[1, 0] = l1 + 2.0 * l0 * c1
    matrix[1, 1] = l1
    matrix[2, 0] = row2 + 2.0 * l0 * c12
    matrix[2, 1] = row2
    matrix[2, 2] = l2
    slopes[:, :, :] = 0.0
    slopes[1, 1, 0] = -2.0 * l0 * s1
    slopes[1, 2, 0] = -2.0 * l0 * s12
    slopes[2, 2, 1] = -2.0 * l1 * s2
    slopes[2, 2, 0] = -2.0 * l1 * s2 - 2.0 * l0 * s12


@kernel
def finger_points(q, half_lengths):
    """Finger joints (MCP at the origin) and fingertip (4), link centres (3), complex."""
    joints = np.zeros(4, np.complex128)
    centres = np.empty(3, np.complex128)
    phi = 0.0
    for k in range(3):
        phi = phi + q[k]
        turn = complex(math.cos(phi), math.sin(phi))
        centres[k] = joints[k] + turn * half_lengths[k]
        joints[k + 1] = joints[k] + turn * (2.0 * half_lengths[k])
    return joints, centres
