"""Entry kernels of the forward solve: one state, rows of states, and the checks of a result.

The unknowns x are the angles q (rad), followed by the bottom strains ε with extensible
segments (``GloveConstants.extensible``); ``motion`` describes the finger of each solve
(rows q_prev, given speed, effort: :func:`.statics.finger_load`).
"""

from __future__ import annotations

import numpy as np

from .constants import LAW_ROM_MAX, LAW_ROM_MIN
from .jit import kernel
from .newton import newton


@kernel
def solve_state(glove, pressure, x, free, motion, rate):
    """Newton from ``x`` (updated in place) at ``pressure`` (Pa).

    Returns status, iterations, residual norm (N·m), f (N) and τ_H (N·m).
    """
    forces = np.empty(3)
    torque = np.empty(3)
    status, iterations, residual = newton(glove, x, pressure, free, motion, rate, forces, torque)
    return status, iterations, residual, forces, torque


@kernel
def solve_rows(glove, pressures, starts, free, motions, rate):
    """:func:`solve_state` for every row: pressures (N, 3), starts (N, n), motions (N, 3, 3).

    Returns x (N, n), f (N, 3), τ_H (N, 3), status (N,), iterations (N,), residual (N,).
    """
    rows = pressures.shape[0]
    x = starts.copy()
    forces = np.empty((rows, 3))
    torque = np.empty((rows, 3))
    status = np.empty(rows, np.int64)
    iterations = np.empty(rows, np.int64)
    residual = np.empty(rows)
    for r in range(rows):
        status[r], iterations[r], residual[r] = newton(
            glove, x[r], pressures[r], free, motions[r], rate, forces[r], torque[r]
        )
    return x, forces, torque, status, iterations, residual


@kernel
def stretch_in_range(glove, x, low, high):
    """Whether every fibre's stretch (12.1) lies in [low, high] (the bottom face and the top)."""
    for k in range(3):
        bottom = 1.0 + x[3 + k] if x.size == 6 else 1.0
        top = bottom + x[k] * glove.strain_per_angle[k]
        if not (low <= bottom <= high and low <= top <= high):
            return False
    return True


@kernel
def in_range_of_motion(glove, q):
    """Whether every joint lies in its range of motion [rom_min, rom_max]."""
    for k in range(3):  # noqa: SIM110 (numba compiles no generator expressions)
        if not glove.laws[k, LAW_ROM_MIN] <= q[k] <= glove.laws[k, LAW_ROM_MAX]:
            return False
    return True


@kernel
def validity_rows(glove, x, low, high):
    """Rows of x (N, n): :func:`stretch_in_range`, :func:`in_range_of_motion`."""
    rows = x.shape[0]
    valid = np.empty(rows, np.bool_)
    moving_range = np.empty(rows, np.bool_)
    for r in range(rows):
        valid[r] = stretch_in_range(glove, x[r], low, high)
        moving_range[r] = in_range_of_motion(glove, x[r])
    return valid, moving_range
