"""One glove (or many) stepped in time (docs/model.md §13): chambers, then the solve.

A step of length Δt from the state (x, p) under the command u:

1. chambers: u is clipped to [0, supply] and p ← u + (p − u)·exp(−Δt/T) (exact zero-order
   hold; ``decay`` = exp(−Δt/T), 0 for an ideal chamber);
2. the stepped solve (11.4) at the new p, q̇ = (q − q_prev)/Δt inside the equation, from the
   last good state (or, for a patient whose torque depends on speed, from where the last step's
   motion goes on: half the Newton steps); a solve that does not converge keeps the last good
   state.

:func:`step_glove` advances one glove in place; :func:`run_glove` takes many steps and records
them; :func:`step_gloves` advances a batch, one glove after the other.
"""

from __future__ import annotations

import numpy as np

from .constants import LAW_DAMPING, LAW_EXTENSOR_SPASTICITY, LAW_SPASTICITY, unpack
from .jit import kernel
from .newton import CONVERGED_STEP, newton
from .solves import in_range_of_motion, stretch_in_range
from .workspace import workspace


@kernel(inline=True)
def moves_with_speed(glove):
    """Whether τ_H depends on the joint speed (damping or spasticity at some joint)."""
    laws = glove.laws
    for k in range(3):
        law = laws[k]
        if law[LAW_DAMPING] > 0.0 or law[LAW_SPASTICITY] > 0.0:
            return True
        if law[LAW_EXTENSOR_SPASTICITY] > 0.0:
            return True
    return False


@kernel(inline=True)
def advance_chambers(pressure, command, decay, supply):
    """Clip ``command`` to [0, supply] and lag ``pressure`` toward it, both in place (Pa).

    Returns whether the command was below zero and whether it was above the supply.
    """
    below = above = False
    for k in range(3):
        if command[k] < 0.0:
            below = True
            command[k] = 0.0
        elif command[k] > supply:
            above = True
            command[k] = supply
        pressure[k] = command[k] + (pressure[k] - command[k]) * decay
    return below, above


@kernel
def step_glove(glove, work, state, command, effort, decay, supply, rate, valid_low, valid_high):
    """One glove one step on: the new state in new arrays (the inputs are left as they are).

    Parameters
    ----------
    glove : GloveConstants
    work : Workspace
        Scratch (:mod:`.workspace`).
    state : tuple of ndarray
        (x, q_before, pressure, forces, torque): the unknowns of the last good state, the
        angles one step before it (rad), the chamber pressures (Pa), f (N) and τ_H (N·m).
    command, effort : ndarray, shape (3,)
        The pressure command (Pa) and the patient's voluntary effort (N·m).
    decay, supply, rate : float
        exp(−Δt/T), the supply pressure (Pa) and 1/Δt (1/s).
    valid_low, valid_high : float
        The validated stretch range (12.1).

    Returns
    -------
    state : tuple of ndarray
        (x, q_before, pressure, forces, torque) after the step (the last good x, f, τ_H where
        the solve failed).
    applied, qdot : ndarray
        The clipped command (Pa) and (q − q_prev)/Δt (rad/s).
    outcome : tuple
        status, iterations, residual of the solve, and the flags in_valid_range,
        in_range_of_motion (of the solve's result), below, above (the command clipped at zero,
        at the supply).
    """
    x, q_before, old_pressure, old_forces, old_torque = state
    pressure = old_pressure.copy()
    applied = command.copy()
    below, above = advance_chambers(pressure, applied, decay, supply)
    motion = np.zeros((3, 3))
    start = x.copy()
    for k in range(3):
        motion[0, k] = x[k]
        motion[2, k] = effort[k]
    if moves_with_speed(glove):
        for k in range(3):
            start[k] = 2.0 * x[k] - q_before[k]
    forces = np.empty(3)
    torque = np.empty(3)
    status, iterations, residual = newton(
        glove, work, start, pressure, False, motion, rate, forces, torque
    )
    valid = stretch_in_range(glove, start, valid_low, valid_high)
    moving_range = in_range_of_motion(glove, start)
    if status > CONVERGED_STEP:
        start[:] = x
        forces[:] = old_forces
        torque[:] = old_torque
    qdot = np.empty(3)
    for k in range(3):
        qdot[k] = (start[k] - x[k]) * rate
    outcome = (status, iterations, residual, valid, moving_range, below, above)
    return (start, x[:3].copy(), pressure, forces, torque), applied, qdot, outcome


@kernel
def step_one(packed, state, command, effort, decay, supply, rate, valid_low, valid_high):
    """:func:`step_glove` from Python (``packed`` constants)."""
    glove, work = unpack(packed), workspace()
    return step_glove(
        glove, work, state, command, effort, decay, supply, rate, valid_low, valid_high
    )


@kernel
def run_glove(packed, state, commands, efforts, decay, supply, rate, valid_low, valid_high):
    """:func:`step_glove` for every row of ``commands`` and ``efforts`` (T, 3), recorded.

    Returns
    -------
    state : tuple of ndarray
        The state after the last step.
    record : tuple of ndarray
        Per step: the clipped command, the pressure, q̇, f, τ_H (T, 3) and the unknowns x
        (T, n); status, iterations, residual (T,); the flags of the outcome (T, 4).
    """
    glove, work = unpack(packed), workspace()
    steps = commands.shape[0]
    n = state[0].size
    applied = np.empty((steps, 3))
    pressure = np.empty((steps, 3))
    qdot = np.empty((steps, 3))
    forces = np.empty((steps, 3))
    torque = np.empty((steps, 3))
    unknowns = np.empty((steps, n))
    status = np.empty(steps, np.int64)
    iterations = np.empty(steps, np.int64)
    residual = np.empty(steps)
    flags = np.empty((steps, 4), np.bool_)
    for t in range(steps):
        state, applied[t], qdot[t], outcome = step_glove(
            glove, work, state, commands[t], efforts[t], decay, supply, rate, valid_low, valid_high
        )
        unknowns[t], pressure[t], forces[t], torque[t] = state[0], state[2], state[3], state[4]
        status[t], iterations[t], residual[t] = outcome[0], outcome[1], outcome[2]
        flags[t, 0], flags[t, 1], flags[t, 2], flags[t, 3] = outcome[3:]
    record = (
        applied,
        pressure,
        qdot,
        forces,
        torque,
        unknowns,
        status,
        iterations,
        residual,
        flags,
    )
    return state, record


@kernel
def step_gloves(packed, states, commands, efforts, decay, supply, rate, valid_low, valid_high):
    """:func:`step_glove` for every glove of a batch: ``states`` of arrays with a leading N.

    Returns the new states, the clipped commands, q̇ (N, 3), status, iterations, residual (N,)
    and the flags (N, 4) of :func:`run_glove`.
    """
    glove, work = unpack(packed), workspace()
    rows = commands.shape[0]
    new = (
        states[0].copy(),
        states[1].copy(),
        states[2].copy(),
        states[3].copy(),
        states[4].copy(),
    )
    applied = np.empty((rows, 3))
    qdot = np.empty((rows, 3))
    status = np.empty(rows, np.int64)
    iterations = np.empty(rows, np.int64)
    residual = np.empty(rows)
    flags = np.empty((rows, 4), np.bool_)
    for r in range(rows):
        state = (states[0][r], states[1][r], states[2][r], states[3][r], states[4][r])
        state, applied[r], qdot[r], outcome = step_glove(
            glove, work, state, commands[r], efforts[r], decay, supply, rate, valid_low, valid_high
        )
        for j in range(5):
            new[j][r] = state[j]
        status[r], iterations[r], residual[r] = outcome[0], outcome[1], outcome[2]
        flags[r, 0], flags[r, 1], flags[r, 2], flags[r, 3] = outcome[3:]
    return new, applied, qdot, status, iterations, residual, flags
