"""Scratch arrays for the kernels, allocated once per solve, run or batch instead of per call.

An evaluation of the statics needs some forty small arrays (Jacobians, their slopes, the
kinematics' complex frames, the Newton iteration's trial state). Allocated afresh at every call
they cost more than the arithmetic; :func:`workspace` carves them all, as views, out of one
real and one complex array, and the kernels fill them in place.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from .jit import kernel
from .valves import AIR_COLUMNS, GAS_ROWS

MAX_UNKNOWNS = 6
"""Unknowns of the largest solve: q and ε of the extensible glove."""


class Workspace(NamedTuple):
    """Views into two scratch arrays (shapes in brackets; ``[i, k]`` contact i, joint k).

    Kinematics: ``j_robot`` J_R* (3, 3); ``robot_slopes`` [m, i, k] ∂J_R*[i, k]/∂q_m (3, 3, 3);
    ``j_length`` J_ℓ* (3, 3); ``length_slopes`` [m, i, k] ∂J_ℓ*[i, k]/∂q_m;
    ``robot_length_slopes`` [k, i, m] ∂J_R*[i, m]/∂ℓ_k; ``j_finger`` J_H* (3, 3) and
    ``finger_slopes`` [m, i, k] (3, 3, 3); complex per joint: ``half_turn`` e^{iq/2}, ``chord``
    C, ``chord_slope`` C', ``curvature`` C''; complex frames ``turns`` (4), ``origins`` (4),
    ``centres`` (3) and ``local`` A_ik (3, 3).
    Statics, per segment (3): ``lengths`` ℓ, ``tau`` τ_s, ``tau_slope``, ``moment_rate``
    ∂M/∂ε, ``axial`` N, ``force_rate`` ∂N/∂ε, ``coupling`` (J_R*)ᵀ f, ``stretching``
    (J_ℓ*)ᵀ f, ``load_slopes`` dτ_H/dq, and the vectors ``rhs``, ``force_slope``, ``column``.
    Newton (MAX_UNKNOWNS, or its square): ``residual``, ``jacobian``, ``trial``,
    ``trial_residual``, ``trial_jacobian``, ``step``, ``matrix`` (the linear solve's copy);
    ``trial_forces`` and ``trial_torque`` (3). Stepping: ``motion`` (3, 3), the finger's
    history of a step (:func:`.statics.finger_load`). Valves (docs/spec/model.md §14): ``air``
    (3, AIR_COLUMNS), the chambers' pneumatic constants (:mod:`.valves`), and ``masses`` (3),
    their air masses, kg: with masses (behind valves) the chambers take their pressures from
    the gas law (14.2) at the unknowns, without (zeros, as a fresh workspace has) the ones
    they are given;
    ``gauge`` (3), the pressures of the last residual, Pa, and ``spring`` (3), their slopes
    ∂p/∂V, Pa/m³ (:func:`.statics.residual_of`); ``air_scratch`` (5, 3), the integration's,
    ``predicted`` (3), the volumes V̂ it integrated toward, m³, and ``mass_slopes`` (3),
    ∂m/∂V̂, kg/m³ (:func:`.valves.admit_air`). A valve step split in several
    (:func:`.stepping.split_step`) keeps the state between them in ``split_unknowns``
    (MAX_UNKNOWNS), ``split_angles`` (3), ``split_pressure`` (3), ``split_forces`` (3),
    ``split_torque`` (3), ``split_earlier`` (2, 3) and ``split_gas`` (GAS_ROWS, 3).
    """

    j_robot: np.ndarray
    robot_slopes: np.ndarray
    j_length: np.ndarray
    length_slopes: np.ndarray
    robot_length_slopes: np.ndarray
    j_finger: np.ndarray
    finger_slopes: np.ndarray
    lengths: np.ndarray
    tau: np.ndarray
    tau_slope: np.ndarray
    moment_rate: np.ndarray
    axial: np.ndarray
    force_rate: np.ndarray
    coupling: np.ndarray
    stretching: np.ndarray
    load_slopes: np.ndarray
    rhs: np.ndarray
    force_slope: np.ndarray
    column: np.ndarray
    residual: np.ndarray
    jacobian: np.ndarray
    trial: np.ndarray
    trial_residual: np.ndarray
    trial_jacobian: np.ndarray
    step: np.ndarray
    matrix: np.ndarray
    trial_forces: np.ndarray
    trial_torque: np.ndarray
    motion: np.ndarray
    air: np.ndarray
    masses: np.ndarray
    gauge: np.ndarray
    spring: np.ndarray
    air_scratch: np.ndarray
    predicted: np.ndarray
    mass_slopes: np.ndarray
    split_unknowns: np.ndarray
    split_angles: np.ndarray
    split_pressure: np.ndarray
    split_forces: np.ndarray
    split_torque: np.ndarray
    split_earlier: np.ndarray
    split_gas: np.ndarray
    half_turn: np.ndarray
    chord: np.ndarray
    chord_slope: np.ndarray
    curvature: np.ndarray
    turns: np.ndarray
    origins: np.ndarray
    centres: np.ndarray
    local: np.ndarray


_SQUARE = MAX_UNKNOWNS * MAX_UNKNOWNS
_REAL = (
    *(9, 27, 9, 27, 27, 9, 27, *(3,) * 12, 6, _SQUARE, 6, 6, _SQUARE, 6, _SQUARE, 3, 3, 9),
    *(3 * AIR_COLUMNS, 3, 3, 3, 15, 3, 3),
    *(MAX_UNKNOWNS, 3, 3, 3, 3, 6, 3 * GAS_ROWS),
)
"""Sizes of the real fields, in order."""
_REAL_ENDS = tuple(int(end) for end in np.cumsum(_REAL))
_COMPLEX = (3, 3, 3, 3, 4, 4, 3, 9)
"""Sizes of the complex fields, in order."""
_COMPLEX_ENDS = tuple(int(end) for end in np.cumsum(_COMPLEX))


@kernel
def workspace():
    """A fresh :class:`Workspace` (two allocations)."""
    r = np.zeros(_REAL_ENDS[-1])
    c = np.zeros(_COMPLEX_ENDS[-1], np.complex128)
    e = _REAL_ENDS
    z = _COMPLEX_ENDS
    return Workspace(
        r[0 : e[0]].reshape((3, 3)),
        r[e[0] : e[1]].reshape((3, 3, 3)),
        r[e[1] : e[2]].reshape((3, 3)),
        r[e[2] : e[3]].reshape((3, 3, 3)),
        r[e[3] : e[4]].reshape((3, 3, 3)),
        r[e[4] : e[5]].reshape((3, 3)),
        r[e[5] : e[6]].reshape((3, 3, 3)),
        r[e[6] : e[7]],
        r[e[7] : e[8]],
        r[e[8] : e[9]],
        r[e[9] : e[10]],
        r[e[10] : e[11]],
        r[e[11] : e[12]],
        r[e[12] : e[13]],
        r[e[13] : e[14]],
        r[e[14] : e[15]],
        r[e[15] : e[16]],
        r[e[16] : e[17]],
        r[e[17] : e[18]],
        r[e[18] : e[19]],
        r[e[19] : e[20]],
        r[e[20] : e[21]],
        r[e[21] : e[22]],
        r[e[22] : e[23]],
        r[e[23] : e[24]],
        r[e[24] : e[25]],
        r[e[25] : e[26]],
        r[e[26] : e[27]],
        r[e[27] : e[28]].reshape((3, 3)),
        r[e[28] : e[29]].reshape((3, AIR_COLUMNS)),
        r[e[29] : e[30]],
        r[e[30] : e[31]],
        r[e[31] : e[32]],
        r[e[32] : e[33]].reshape((5, 3)),
        r[e[33] : e[34]],
        r[e[34] : e[35]],
        r[e[35] : e[36]],
        r[e[36] : e[37]],
        r[e[37] : e[38]],
        r[e[38] : e[39]],
        r[e[39] : e[40]],
        r[e[40] : e[41]].reshape((2, 3)),
        r[e[41] : e[42]].reshape((GAS_ROWS, 3)),
        c[0 : z[0]],
        c[z[0] : z[1]],
        c[z[1] : z[2]],
        c[z[2] : z[3]],
        c[z[3] : z[4]],
        c[z[4] : z[5]],
        c[z[5] : z[6]],
        c[z[6] : z[7]].reshape((3, 3)),
    )
