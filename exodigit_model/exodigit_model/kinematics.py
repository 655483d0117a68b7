r"""Planar kinematics of the exo-digit and the finger, and their contact Jacobians (MODEL.md §2-3).

Points of the plane are complex numbers z = x + iy and a rotation by a is a product with
e^{ia}. Joint order is MCP, PIP, DIP (index 0, 1, 2); φ_j = q_0 + … + q_{j-1} is the
orientation of body j (φ_0 = 0, the base).

**Exo-digit** (eqs 1-4, y-row of eq 4 corrected, MODEL.md §9). Body 0 is the base block of
length 2·d_0; soft arc k joins body k to body k+1, whose block has length 2·d_{k+1} and its
centre of mass at d_{k+1} from its proximal end. An arc of length ℓ̂ bent by q has chord

.. math:: \hat\ell\,C(q), \qquad C(q) = \frac{e^{iq} - 1}{iq}
          = \frac{\sin(q/2)}{q/2}\,e^{iq/2}

(x = ℓ̂ sin q / q, y = ℓ̂ (1 - cos q)/q, smooth at q = 0 in the sinc form), so the origin of body
k+1 is z_{k+1} = z_k + e^{iφ_k}(2 d_k + ℓ̂_k C(q_k)) and its centre zc_k = z_{k+1} + e^{iφ_{k+1}}
d_{k+1}.

**Finger** (eqs 32-34): hinges instead of arcs, no base block, link k of length 2·ℓ_k with its
centre at ℓ_k from joint k. Its Jacobian is the robot's formula with ℓ̂ = 0, which reduces to
the closed form of :func:`finger_jacobian` (the paper's printed (J_H*)ᵀ, transposed).

**Contact Jacobians** (MODEL.md §3). Contact k pushes along the normal n_k = i e^{iφ_{k+1}} at
the centre of body (link) k, so J*[i, k] = n_i · ∂zc_i/∂q_k. With D_ik = ∂zc_i/∂q_k =
i(zc_i - z_{k+1}) + e^{iφ_k} ℓ̂_k C'(q_k) for k ≤ i (a rotation about the distal end of arc k
plus the change of the arc's own chord) and A_ik = e^{-iφ_{i+1}} D_ik,

.. math:: J^*_{ik} = \operatorname{Im} A_{ik}, \qquad
          \frac{\partial J^*_{ik}}{\partial q_m} = \begin{cases}
          \operatorname{Re}(A_{im} - A_{ik}) & k < m \le i \\
          -\operatorname{Re} A_{ik} + \operatorname{Im}\bigl(e^{-i\varphi_{i+1}}
          (e^{i\varphi_k}\hat\ell_k C''(q_k) - (zc_i - z_{k+1}))\bigr) & m = k \\
          0 & \text{otherwise.} \end{cases}

Both Jacobians are lower triangular with diagonals d_{k+1} + ℓ̂_k (1 - cos q_k)/q_k² (robot)
and ℓ_k (finger), positive for every q. The printed (J_R*)ᵀ of the paper does not follow from its
own kinematics (MODEL.md §3); this module follows the definition.

Functions take per-joint sequences whose items are floats (one state) or 1-D arrays (a batch);
``ops`` is the matching backend of :mod:`._backend`.
"""

from __future__ import annotations

from dataclasses import dataclass

SERIES_LIMIT = 0.25
"""Below this half-angle, sinc and its derivatives come from their Taylor series."""

# Taylor coefficients of s(x) = sin(x)/x in powers of x²: (-1)^n / (2n+1)!.
_SINC_SERIES = (1.0, -1.0 / 6.0, 1.0 / 120.0, -1.0 / 5040.0, 1.0 / 362880.0, -1.0 / 39916800.0)


def _sinc_series(x):
    """s, s', s'' from the Taylor series in x² (error below 1e-17 for |x| < SERIES_LIMIT)."""
    a = _SINC_SERIES
    x2 = x * x
    s = a[0] + x2 * (a[1] + x2 * (a[2] + x2 * (a[3] + x2 * (a[4] + x2 * a[5]))))
    s1 = x * (2 * a[1] + x2 * (4 * a[2] + x2 * (6 * a[3] + x2 * (8 * a[4] + x2 * 10 * a[5]))))
    s2 = 2 * a[1] + x2 * (12 * a[2] + x2 * (30 * a[3] + x2 * (56 * a[4] + x2 * 90 * a[5])))
    return s, s1, s2


def _sinc_closed(x, sin_x, cos_x):
    """s, s', s'' from sin and cos (cancels catastrophically for small |x|)."""
    s = sin_x / x
    s1 = (cos_x - s) / x
    return s, s1, -s - 2.0 * s1 / x


def sinc_derivatives(x, sin_x, cos_x, ops):
    """s(x) = sin(x)/x and its first two derivatives, smooth and accurate at x = 0.

    The closed forms cancel catastrophically for small |x|, where the Taylor series is used.
    """
    return ops.piecewise(
        abs(x) < SERIES_LIMIT, _sinc_series, lambda x_: _sinc_closed(x_, sin_x, cos_x), x
    )


@dataclass(frozen=True)
class Chords:
    """Per joint: e^{iq/2}, the unit chord C(q) and C'(q); C''(q) on request."""

    half_turn: tuple
    chord: tuple
    chord_slope: tuple
    sincs: tuple

    def curvature(self, k: int):
        """C''(q_k) = e^{iq/2} (s'' - s + 2i s')/4 with s = sinc(q/2)."""
        s, s1, s2 = self.sincs[k]
        return 0.25 * self.half_turn[k] * (s2 - s + 2j * s1)


def chords(q, ops) -> Chords:
    """C(q_k) = sinc(q_k/2) e^{iq_k/2} and C'(q_k) for the three joints (module docstring)."""
    half_turn, chord, slope, sincs = [], [], [], []
    for qk in q:
        x = 0.5 * qk
        sin_x, cos_x = ops.sin(x), ops.cos(x)
        s, s1, s2 = sinc_derivatives(x, sin_x, cos_x, ops)
        h = cos_x + 1j * sin_x
        half_turn.append(h)
        chord.append(s * h)
        slope.append(0.5 * h * (s1 + 1j * s))
        sincs.append((s, s1, s2))
    return Chords(tuple(half_turn), tuple(chord), tuple(slope), tuple(sincs))


@dataclass(frozen=True)
class Chain:
    """Frames of the exo-digit's bodies.

    Attributes
    ----------
    turns : tuple
        e^{iφ_j}, j = 0..3 (base, then bodies 1-3).
    origins : tuple
        z_j, proximal ends of bodies 0..3.
    centres : tuple
        zc_k, contact points (centres of mass) of bodies 1-3.
    """

    turns: tuple
    origins: tuple
    centres: tuple


def chain(chord_set: Chords, arc_lengths, half_lengths) -> Chain:
    """Frames of the exo-digit: ``arc_lengths`` ℓ̂_1..ℓ̂_3, ``half_lengths`` d_0..d_3 (eq 4)."""
    turns = [1.0 + 0j]
    origins = [0j]
    centres = []
    for k in range(3):
        turn = turns[k]
        chord = arc_lengths[k] * chord_set.chord[k]
        origins.append(origins[k] + turn * (2.0 * half_lengths[k] + chord))
        h = chord_set.half_turn[k]
        turns.append(turn * h * h)
        centres.append(origins[k + 1] + turns[k + 1] * half_lengths[k + 1])
    return Chain(tuple(turns), tuple(origins), tuple(centres))


@dataclass(frozen=True)
class RobotJacobian:
    """J_R* and the pieces its slopes are made of (see the module docstring).

    Attributes
    ----------
    matrix : list of list
        J_R*[i][k], zero above the diagonal.
    local : dict
        A_ik keyed by (i, k), k ≤ i: ∂zc_i/∂q_k in the frame of body i+1.
    to_centre : dict
        e^{-iφ_{i+1}}(zc_i - z_{k+1}) keyed by (i, k).
    arc_turn : dict
        e^{-i(φ_{i+1} - φ_k)} ℓ̂_k keyed by (i, k).
    chord_set : Chords
    """

    matrix: list
    local: dict
    to_centre: dict
    arc_turn: dict
    chord_set: Chords

    def slopes(self) -> list:
        """∂J_R*[i][k]/∂q_m as ``slopes[m]`` = list of (i, k, value); others are zero."""
        local, slopes = self.local, [[], [], []]
        curvatures = [self.chord_set.curvature(k) for k in range(3)]
        for (i, k), a_ik in local.items():
            curvature = self.arc_turn[i, k] * curvatures[k] - self.to_centre[i, k]
            slopes[k].append((i, k, curvature.imag - a_ik.real))
            for m in range(k + 1, i + 1):
                slopes[m].append((i, k, (local[i, m] - a_ik).real))
        return slopes

    def length_terms(self, arc_lengths) -> tuple[list, list, list]:
        r"""What extensible segments add (MODEL.md §12): J_ℓ* and the mixed slopes.

        With B_ik = e^{i(φ_k − φ_{i+1})} C(q_k) the chord direction of arc k seen from body i+1,
        ∂zc_i/∂ℓ_k = e^{iφ_k} C(q_k) for k ≤ i, so

        .. math:: J^*_{\ell,ik} = \operatorname{Im} B_{ik}, \qquad
                  \frac{\partial J^*_{\ell,ik}}{\partial q_m} = -\operatorname{Re} B_{ik}
                  + [m = k] \operatorname{Im}(e^{i(\varphi_k - \varphi_{i+1})} C'(q_k))
                  \quad (k \le m \le i),

        .. math:: \frac{\partial J^*_{R,im}}{\partial \ell_k} = \operatorname{Re} B_{ik}
                  \ (m < k \le i), \qquad
                  \frac{\partial J^*_{R,ik}}{\partial \ell_k}
                  = \operatorname{Im}(e^{i(\varphi_k - \varphi_{i+1})} C'(q_k)).

        Returns
        -------
        matrix : list of list
            J_ℓ*[i][k], zero above the diagonal.
        slopes : list
            ``slopes[m]`` = list of (i, k, ∂J_ℓ*[i][k]/∂q_m).
        robot_slopes : list
            ``robot_slopes[k]`` = list of (i, m, ∂J_R*[i][m]/∂ℓ_k).
        """
        zero = 0.0 * self.chord_set.chord[0].real
        matrix = [[zero, zero, zero], [zero, zero, zero], [zero, zero, zero]]
        slopes, robot_slopes = [[], [], []], [[], [], []]
        chord, chord_slope = self.chord_set.chord, self.chord_set.chord_slope
        for (i, k), turn in self.arc_turn.items():
            unit_turn = turn / arc_lengths[k]
            b = unit_turn * chord[k]
            b_slope = (unit_turn * chord_slope[k]).imag
            matrix[i][k] = b.imag
            slopes[k].append((i, k, b_slope - b.real))
            for m in range(k + 1, i + 1):
                slopes[m].append((i, k, -b.real))
            robot_slopes[k].append((i, k, b_slope))
            for m in range(k):
                robot_slopes[k].append((i, m, b.real))
        return matrix, slopes, robot_slopes


def robot_jacobian(chord_set: Chords, arc_lengths, half_lengths) -> RobotJacobian:
    """J_R*[i][k] = n_i · ∂zc_i/∂q_k of the exo-digit (MODEL.md §3), with its slope pieces."""
    frames = chain(chord_set, arc_lengths, half_lengths)
    turns, origins = frames.turns, frames.origins
    zero = 0.0 * chord_set.chord[0].real
    matrix = [[zero, zero, zero], [zero, zero, zero], [zero, zero, zero]]
    local, to_centre, arc_turn = {}, {}, {}
    for i in range(3):
        back = turns[i + 1].conjugate()
        centre = frames.centres[i]
        for k in range(i + 1):
            relative = back * (centre - origins[k + 1])
            turn = back * turns[k] * arc_lengths[k]
            a_ik = 1j * relative + turn * chord_set.chord_slope[k]
            matrix[i][k] = a_ik.imag
            local[i, k], to_centre[i, k], arc_turn[i, k] = a_ik, relative, turn
    return RobotJacobian(matrix, local, to_centre, arc_turn, chord_set)


def finger_jacobian(q, ops, half_lengths) -> tuple[list, list]:
    """J_H*[i][k] of the finger and its slopes as ``slopes[m]`` = list of (i, k, ∂J[i][k]/∂q_m).

    The contact on link i sits at ℓ_i from joint i and pushes along the link's normal, so
    J_H*[i][k] = ℓ_i + Σ_{j=k}^{i-1} 2ℓ_j cos(q_{j+1} + … + q_i): the paper's printed
    (J_H*)ᵀ. ``half_lengths`` are ℓ_1..ℓ_3.
    """
    l0, l1, l2 = half_lengths
    c1, s1 = ops.cos(q[1]), ops.sin(q[1])
    c2, s2 = ops.cos(q[2]), ops.sin(q[2])
    q12 = q[1] + q[2]
    c12, s12 = ops.cos(q12), ops.sin(q12)
    zero = 0.0 * c1
    row2 = l2 + 2.0 * l1 * c2
    matrix = [
        [l0 + zero, zero, zero],
        [l1 + 2.0 * l0 * c1, l1 + zero, zero],
        [row2 + 2.0 * l0 * c12, row2, l2 + zero],
    ]
    slopes = [
        [],
        [(1, 0, -2.0 * l0 * s1), (2, 0, -2.0 * l0 * s12)],
        [(2, 1, -2.0 * l1 * s2), (2, 0, -2.0 * l1 * s2 - 2.0 * l0 * s12)],
    ]
    return matrix, slopes


def finger_chain(q, ops, half_lengths) -> tuple[tuple, tuple]:
    """Finger joints (MCP at the origin), fingertip and link centres as complex points."""
    joints = [0j]
    centres = []
    phi = 0.0
    for k in range(3):
        phi = phi + q[k]
        turn = ops.cos(phi) + 1j * ops.sin(phi)
        centres.append(joints[k] + turn * half_lengths[k])
        joints.append(joints[k] + turn * (2.0 * half_lengths[k]))
    return tuple(joints), tuple(centres)


def arc_points(q, arc_lengths, half_lengths, samples: int, ops) -> list:
    """Points along each soft arc (complex, ``samples`` per arc, both ends included).

    A point at fraction s of arc k is z_k + e^{iφ_k}(2 d_k + s ℓ̂_k C(s q_k)): the arc is
    traced by the same chord formula with a shorter length and angle.
    """
    frames = chain(chords(q, ops), arc_lengths, half_lengths)
    arcs = []
    for k in range(3):
        start = frames.origins[k] + frames.turns[k] * (2.0 * half_lengths[k])
        points = []
        for n in range(samples):
            fraction = n / (samples - 1)
            partial = chords([fraction * q[k]], ops).chord[0]
            points.append(start + frames.turns[k] * (fraction * arc_lengths[k]) * partial)
        arcs.append(points)
    return arcs
