"""Entry kernels of the forward solve: one state, rows of states, and the checks of a result.

The unknowns x are the angles q (rad), followed by the bottom strains ε with extensible
segments (``GloveConstants.extensible``); ``motion`` describes the finger of each solve
(rows q_prev, given speed, effort: :func:`.statics.finger_load`).
"""

from __future__ import annotations

import numpy as np

from .constants import LAW_ROM_MAX, LAW_ROM_MIN, unpack, with_finger
from .jit import kernel
from .kinematics import finger_terms, robot_terms
from .newton import newton
from .statics import evaluate, finger_load
from .workspace import MAX_UNKNOWNS, workspace


@kernel
def solve_state(packed, pressure, x, free, motion, limits):
    """Newton from ``x`` (updated in place) at ``pressure`` (Pa), ``packed`` constants.

    ``limits``: 1/Δt of a stepped solve (1/s, 0 for a static one) and the validated stretch
    range (12.1), low and high. Returns status, iterations, residual norm (N·m), f (N), τ_H
    (N·m) and the checks of the result, :func:`stretch_in_range` and
    :func:`in_range_of_motion` (one call from Python for the whole public solve).
    """
    rate, valid_low, valid_high = limits
    glove = unpack(packed)
    forces = np.empty(3)
    torque = np.empty(3)
    work = workspace()
    work.motion[:, :] = motion  # the one type of motion below (read-only from Python)
    status, iterations, residual = newton(
        glove, work, x, pressure, free, work.motion, rate, forces, torque
    )
    valid = stretch_in_range(glove, x, valid_low, valid_high)
    return status, iterations, residual, forces, torque, valid, in_range_of_motion(glove, x)


@kernel
def solve_rows(packed, pressures, starts, free, motions, rate):
    """:func:`solve_state` for every row: pressures (N, 3), starts (N, n), motions (N, 3, 3).

    Returns x (N, n), f (N, 3), τ_H (N, 3), status (N,), iterations (N,), residual (N,).
    """
    glove = unpack(packed)
    rows = pressures.shape[0]
    x = starts.copy()
    forces = np.empty((rows, 3))
    torque = np.empty((rows, 3))
    status = np.empty(rows, np.int64)
    iterations = np.empty(rows, np.int64)
    residual = np.empty(rows)
    work = workspace()
    for r in range(rows):
        work.motion[:, :] = motions[r]  # as in solve_state
        status[r], iterations[r], residual[r] = newton(
            glove, work, x[r], pressures[r], free, work.motion, rate, forces[r], torque[r]
        )
    return x, forces, torque, status, iterations, residual


@kernel(counted=False, forceinline=True)
def stretch_in_range(glove, x, low, high):
    """Whether every fibre's stretch (12.1) lies in [low, high] (the bottom face and the top)."""
    strain_per_angle = glove.strain_per_angle
    for k in range(3):
        bottom = 1.0 + x[3 + k] if x.size == 6 else 1.0
        top = bottom + x[k] * strain_per_angle[k]
        if not (low <= bottom <= high and low <= top <= high):
            return False
    return True


@kernel(counted=False, forceinline=True)
def in_range_of_motion(glove, q):
    """Whether every joint lies in its range of motion [rom_min, rom_max]."""
    laws = glove.laws
    for k in range(3):  # noqa: SIM110 (numba compiles no generator expressions)
        if not laws[k, LAW_ROM_MIN] <= q[k] <= laws[k, LAW_ROM_MAX]:
            return False
    return True


@kernel
def validity_rows(packed, x, low, high):
    """Rows of x (N, n): :func:`stretch_in_range`, :func:`in_range_of_motion`."""
    glove = unpack(packed)
    rows = x.shape[0]
    valid = np.empty(rows, np.bool_)
    moving_range = np.empty(rows, np.bool_)
    for r in range(rows):
        valid[r] = stretch_in_range(glove, x[r], low, high)
        moving_range[r] = in_range_of_motion(glove, x[r])
    return valid, moving_range


@kernel
def rest_rows(packed, finger_half_lengths, laws, valid_low, valid_high):
    """Each glove of a batch at rest, on its own finger: vented, static, no effort.

    Row r solves (11.4) at p = 0 with q̇ = 0 and u = 0 from x = 0, as :func:`solve_state` does
    from zero, for the exo-digit of ``packed`` on the finger of row r of ``finger_half_lengths``
    (N, 3), m, and ``laws`` (N, 3, LAW_COLUMNS) (:func:`.constants.with_finger`); a finger
    whose rest angle is not zero rests bent, pre-loaded (docs/spec/model.md §11).

    Returns x (N, n), f (N, 3), τ_H (N, 3), status (N,), iterations (N,), residual (N,) and the
    checks of :func:`validity_rows`, in_valid_range and in_range_of_motion (N,).
    """
    glove, work = unpack(packed), workspace()
    rows = laws.shape[0]
    x = np.zeros((rows, MAX_UNKNOWNS if glove.extensible else 3))
    forces = np.empty((rows, 3))
    torque = np.empty((rows, 3))
    status = np.empty(rows, np.int64)
    iterations = np.empty(rows, np.int64)
    residual = np.empty(rows)
    valid = np.empty(rows, np.bool_)
    moving_range = np.empty(rows, np.bool_)
    outcomes = (forces, torque, status, iterations, residual, valid, moving_range)
    fingers = (finger_half_lengths, laws)
    rest_into(glove, fingers, work, np.zeros(3), x, outcomes, valid_low, valid_high)
    return x, forces, torque, status, iterations, residual, valid, moving_range


@kernel(counted=False)
def rest_into(glove, fingers, work, vented, x, outcomes, valid_low, valid_high):
    """The rows of :func:`rest_rows`, into ``x`` (zeros) and ``outcomes``; ``vented``: zeros (3,).

    Counts nothing: :func:`.constants.with_finger`'s views may not be released.
    """
    finger_half_lengths, laws = fingers
    forces, torque, status, iterations, residual, valid, moving_range = outcomes
    still = work.motion
    still[:, :] = 0.0
    for r in range(x.shape[0]):
        patient = with_finger(glove, finger_half_lengths[r], laws[r])
        status[r], iterations[r], residual[r] = newton(
            patient, work, x[r], vented, np.bool_(False), still, 0.0, forces[r], torque[r]
        )
        valid[r] = stretch_in_range(patient, x[r], valid_low, valid_high)
        moving_range[r] = in_range_of_motion(patient, x[r])


@kernel
def evaluate_state(packed, x, pressure, free, motion, rate):
    """The residual (N·m) and its Jacobian at unknowns ``x`` (:func:`.statics.evaluate`)."""
    residual = np.empty(x.size)
    jacobian = np.empty((x.size, x.size))
    forces = np.empty(3)
    torque = np.empty(3)
    glove, work = unpack(packed), workspace()
    work.motion[:, :] = motion  # as in solve_state
    finger = work.motion
    evaluate(glove, work, x, pressure, free, finger, rate, residual, jacobian, forces, torque)
    return residual, jacobian


@kernel
def finger_torques(packed, q, motion):
    """τ_H of (11.1) at angles ``q`` for ``motion`` (:func:`.statics.finger_load`), N·m."""
    torque = np.empty(3)
    finger = np.empty((3, 3))  # writable, as in solve_state
    finger[:, :] = motion
    finger_load(unpack(packed), q, finger, 0.0, torque, np.empty(3))
    return torque


@kernel
def jacobians_at(packed, q, lengths):
    """(J_R*, J_H*, J_ℓ*) at angles ``q`` and bottom-face ``lengths`` (m), each (3, 3)."""
    glove, work = unpack(packed), workspace()
    robot_terms(q, lengths, glove.block_half_lengths, np.bool_(True), work)
    finger_terms(q, glove.finger_half_lengths, work.j_finger, work.finger_slopes)
    return work.j_robot.copy(), work.j_finger.copy(), work.j_length.copy()
