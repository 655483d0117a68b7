"""One glove (or many) stepped in time (docs/spec/model.md §13-14): chambers, then the solve.

A step of length Δt from the state (x, p) under the command u:

1. chambers: u is clipped to [0, supply] and p ← u + (p − u)·exp(−Δt/T) (exact zero-order
   hold; ``decay`` = exp(−Δt/T), 0 for an ideal chamber);
2. the stepped solve (11.4) at the new p, q̇ = (q − q_prev)/Δt inside the equation, from a
   prediction of the angles (:func:`predict`: where the last steps' motion goes on, when it is
   smooth); a solve that does not converge keeps the last good state.

Behind valves (§14, given the chambers' pneumatic constants ``air``, one row each; none: the
regulator above) the command is six openings, u_in then u_out: step 1 clips them to [0, 1] and
integrates the chambers' air masses over the step (:func:`.valves.admit_air`), step 2 solves the
statics with the pressures of the gas law at those masses (:mod:`.statics`), and the pressures
and volumes follow from the solved angles (:func:`.valves.settle_air`). The state then carries
the air (``gas``: masses, volumes and the volumes one step before, :mod:`.valves`).

:func:`step_into` advances one glove; :func:`step_one` and :func:`run_glove` take one step or
many (recorded) from Python; :func:`step_gloves` advances a batch, one glove after the other,
each on its own finger (rows of the finger's constants, :func:`.constants.with_finger`): a
population of patients, or the same finger N times.
"""

from __future__ import annotations

import numpy as np

from .constants import (
    LAW_DAMPING,
    LAW_EXTENSOR_SPASTICITY,
    LAW_SPASTICITY,
    unpack,
    with_finger,
)
from .jit import kernel
from .newton import CONVERGED_STEP, newton
from .solves import in_range_of_motion, stretch_in_range
from .valves import GAS_ROWS, GAS_VOLUME, GAS_VOLUME_BEFORE, admit_air, air_steps, settle_air
from .workspace import workspace


@kernel(counted=False, forceinline=True)
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


@kernel(counted=False, forceinline=True)
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


SMOOTH = 0.5
"""A glove's motion is smooth when, at every joint, a quadratic through its three steps before
the last one predicted the last one's angle, and a straight line through the two before it did,
each to within this share of how far the last step moved it."""


@kernel(counted=False, forceinline=True)
def predict(glove, x, q_before, earlier, start):
    """Where the Newton iteration of the next step starts: ``start`` (the unknowns), filled.

    ``x`` holds the last good unknowns, ``q_before`` the angles one step before them and
    ``earlier`` (2, 3) the angles two and three steps before (rad). The solution moves little
    per step, so the iteration starts near it: where the cubic through the last four steps'
    angles goes on, when the motion is smooth (:data:`SMOOTH`), which leaves a smooth command
    a single Newton step to the solver's tolerance, most steps; else, as before, the last good
    angles, or, for a patient whose torque depends on speed, where the last step's motion goes
    on (half the Newton steps of starting still). The bottom strains start where they were.
    Only the start depends on this, not the root the iteration converges to.

    The cubic's step beyond the last angles is the sum of the last three differences of the
    angles, Δq + Δ²q + Δ³q; smooth bounds the second and the third by half the first. The third
    alone is not enough: a glove held still for two steps and then let go back to where it came
    from has Δ³q = 0 with Δ²q = Δq, and the cubic would start it twice as far past its rest
    as it had moved.

    Returns whether the start is not the last good unknowns (a prediction was made).
    """
    smooth = True
    for k in range(3):
        moved = x[k] - q_before[k]
        second = moved - (q_before[k] - earlier[0, k])
        third = second - (q_before[k] - 2.0 * earlier[0, k] + earlier[1, k])
        if max(abs(second), abs(third)) > SMOOTH * abs(moved):
            smooth = False
    for k in range(x.size):
        start[k] = x[k]
    if smooth:
        for k in range(3):
            start[k] = 4.0 * x[k] - 6.0 * q_before[k] + 4.0 * earlier[0, k] - earlier[1, k]
        return True
    if moves_with_speed(glove):
        for k in range(3):
            start[k] = 2.0 * x[k] - q_before[k]
        return True
    return False


@kernel(counted=False, forceinline=True)
def step_into(glove, work, state, new, command, effort, limits, air):
    """One glove one step on, from ``state`` into the arrays of ``new`` (no allocation).

    Behind valves the step is taken as :func:`.valves.air_steps` says: one :func:`advance` in
    its sub-steps, or, when a chamber moves faster than the step resolves, several of a share
    of the step (:func:`split_step`). With regulators one :func:`advance`. Arguments and
    result those of :func:`advance`.
    """
    splits, count = 1, 0
    if air.shape[0] > 0:
        splits, count = air_steps(air, state[6], command, 1.0 / limits[2])
    if splits == 1:
        return advance(glove, work, state, new, command, effort, limits, air, count, 1)
    return split_step(glove, work, state, new, command, effort, limits, air, splits, count)


@kernel(counted=False)
def split_step(glove, work, state, new, command, effort, limits, air, splits, count):
    """A valve step of Δt as ``splits`` steps of Δt/m (:func:`advance`, ``count`` sub-steps).

    The history the first of them predicts from (the angles and volumes of the steps before)
    is the last step's motion scaled to Δt/m. After them the angles' history is that of one
    step of Δt (the angles at its start), as an unsplit step leaves, and the volumes' is the
    last split step's motion m times over (:func:`.valves.settle_air`'s ``scale``): where a
    chamber settled early in the step, the next one predicts it still. Unless the last of
    them failed: then the glove is still, as :func:`advance` leaves it. q̇ is over Δt.
    The outcome: the worst status, the iterations summed, the last residual, the flags of
    the last for the state and of any for the clipping. The state between them is kept in the
    workspace's ``split_*`` arrays. Called for the few steps that split, not inlined.
    """
    x, q_before, pressure, forces, torque, earlier, gas = state
    decay, supply, rate, valid_low, valid_high = limits
    share = 1.0 / splits
    current_x = work.split_unknowns[: x.size]
    current_q_before, current_earlier = work.split_angles, work.split_earlier
    current_gas = work.split_gas
    for k in range(x.size):
        current_x[k] = x[k]
    for k in range(3):
        moved = (x[k] - q_before[k]) * share
        current_q_before[k] = x[k] - moved
        current_earlier[0, k] = x[k] - 2.0 * moved
        current_earlier[1, k] = x[k] - 3.0 * moved
        work.split_pressure[k] = pressure[k]
        work.split_forces[k] = forces[k]
        work.split_torque[k] = torque[k]
        for row in range(GAS_ROWS):
            current_gas[row, k] = gas[row, k]
        volume = gas[GAS_VOLUME, k]
        current_gas[GAS_VOLUME_BEFORE, k] = volume - (volume - gas[GAS_VOLUME_BEFORE, k]) * share
    current = (
        current_x,
        current_q_before,
        work.split_pressure,
        work.split_forces,
        work.split_torque,
        current_earlier,
        current_gas,
    )
    inner = (decay, supply, rate * splits, valid_low, valid_high)
    worst, iterations, below, above = 0, 0, False, False
    outcome = (0, 0, 0.0, True, True, False, False)
    for split in range(splits):
        scale = splits if split == splits - 1 else 1
        outcome = advance(glove, work, current, new, command, effort, inner, air, count, scale)
        worst = max(worst, outcome[0])
        iterations += outcome[1]
        below = below or outcome[5]
        above = above or outcome[6]
        new_x, new_q_before, new_pressure, new_forces, new_torque = new[:5]
        for k in range(x.size):
            current_x[k] = new_x[k]
        for k in range(3):
            current_q_before[k] = new_q_before[k]
            current[2][k] = new_pressure[k]
            current[3][k] = new_forces[k]
            current[4][k] = new_torque[k]
            current_earlier[0, k] = new[7][0, k]
            current_earlier[1, k] = new[7][1, k]
            for row in range(GAS_ROWS):
                current_gas[row, k] = new[8][row, k]
    if outcome[0] <= CONVERGED_STEP:
        for k in range(3):
            new[1][k] = x[k]
            new[7][0, k] = q_before[k]
            new[7][1, k] = earlier[0, k]
    for k in range(3):
        new[6][k] = (new[0][k] - x[k]) * rate
    return worst, iterations, outcome[2], outcome[3], outcome[4], below, above


@kernel(counted=False, forceinline=True)
def advance(glove, work, state, new, command, effort, limits, air, count, scale):
    """One glove one step on, from ``state`` into the arrays of ``new`` (no allocation).

    Parameters
    ----------
    glove : GloveConstants
    work : Workspace
        Scratch (:mod:`.workspace`); its ``motion`` holds the finger's history.
    state : tuple of ndarray
        (x, q_before, pressure, forces, torque, earlier, gas): the unknowns of the last good
        state, the angles one step before it (rad), the chamber pressures (Pa), f (N), τ_H
        (N·m), (2, 3) the angles two and three steps before it (rad; :func:`predict`) and the
        air, (GAS_ROWS, 3) behind valves (:mod:`.valves`), else (0, 3).
    new : tuple of ndarray
        The first five of ``state`` after the step (the last good x, f, τ_H where the solve
        failed), the clipped command (Pa, or openings), q̇ = (q − q_prev)/Δt (rad/s),
        ``earlier`` and ``gas``: filled. Where the solve failed, the glove is still: its
        history is the last good angles (behind valves the air still flows: the masses are
        the step's, the pressures those of the gas law at the last good volumes).
    command, effort : ndarray
        The pressure command (3,), Pa, or behind valves the openings (6,), and the patient's
        voluntary effort (3,), N·m.
    limits : tuple of float
        exp(−Δt/T), the supply pressure (Pa), 1/Δt (1/s) and the validated stretch range
        (12.1), low and high.
    air : ndarray
        The chambers' pneumatic constants, (3, AIR_COLUMNS) behind valves, else (0, 3).
    count : int
        Behind valves, the ROS2 sub-steps of the air (:func:`.valves.air_steps`).
    scale : int
        Behind valves, how many times this step's volume motion the next step predicts
        (:func:`.valves.settle_air`): 1, or m for the last of m split steps.

    Returns
    -------
    tuple
        status, iterations, residual of the solve, and the flags in_valid_range,
        in_range_of_motion (of the solve's result), below, above (the command clipped at zero,
        at the supply).
    """
    x, q_before, pressure, forces, torque, earlier, gas = state
    new_x, new_q_before, new_pressure, new_forces, new_torque, applied, qdot, new_earlier = new[:8]
    new_gas = new[8]
    decay, supply, rate, valid_low, valid_high = limits
    valves = air.shape[0] > 0
    if valves:
        below, above = admit_air(work, air, gas, new_gas, command, applied, 1.0 / rate, count)
    else:
        for k in range(3):
            applied[k] = command[k]
            new_pressure[k] = pressure[k]
        below, above = advance_chambers(new_pressure, applied, decay, supply)
    motion = work.motion
    predicted = predict(glove, x, q_before, earlier, new_x)
    for k in range(3):
        motion[0, k] = x[k]
        motion[1, k] = 0.0
        motion[2, k] = effort[k]
    # A predicted start that does not converge is tried again from the last good unknowns: the
    # prediction may cost Newton steps, never a solve.
    iterations = 0
    for _ in range(2):
        status, taken, residual = newton(
            glove, work, new_x, new_pressure, np.bool_(False), motion, rate, new_forces, new_torque
        )
        iterations += taken
        if status <= CONVERGED_STEP or not predicted:
            break
        predicted = False
        for k in range(x.size):
            new_x[k] = x[k]
    valid = stretch_in_range(glove, new_x, valid_low, valid_high)
    moving_range = in_range_of_motion(glove, new_x)
    failed = status > CONVERGED_STEP
    if failed:
        for k in range(x.size):
            new_x[k] = x[k]
        for k in range(3):
            new_forces[k] = forces[k]
            new_torque[k] = torque[k]
    if valves:
        settle_air(work, air, gas, new_gas, new_x, new_pressure, failed, scale, applied)
    for k in range(3):
        new_earlier[0, k] = x[k] if failed else q_before[k]
        new_earlier[1, k] = x[k] if failed else earlier[0, k]
        new_q_before[k] = x[k]
        qdot[k] = (new_x[k] - x[k]) * rate
    return status, iterations, residual, valid, moving_range, below, above


@kernel
def fresh(n, air):
    """New arrays for one glove's ``new`` of :func:`step_into` (``n`` unknowns, ``air``)."""
    valves = air.shape[0] > 0
    return (
        np.empty(n),
        np.empty(3),
        np.empty(3),
        np.empty(3),
        np.empty(3),
        np.empty(6 if valves else 3),
        np.empty(3),
        np.empty((2, 3)),
        np.empty((GAS_ROWS if valves else 0, 3)),
    )


@kernel
def fresh_rows(rows, n, air):
    """New arrays for a batch's ``new`` of :func:`step_into`: :func:`fresh` with a leading N."""
    valves = air.shape[0] > 0
    return (
        np.empty((rows, n)),
        np.empty((rows, 3)),
        np.empty((rows, 3)),
        np.empty((rows, 3)),
        np.empty((rows, 3)),
        np.empty((rows, 6 if valves else 3)),
        np.empty((rows, 3)),
        np.empty((rows, 2, 3)),
        np.empty((rows, GAS_ROWS if valves else 0, 3)),
    )


@kernel
def step_one(packed, block, command, effort, decay, supply, rate, valid_low, valid_high):
    """One glove one step on under a pressure command, from Python: :func:`step_into`.

    The state travels as one array (fewer arrays to pass between Python and compiled code):
    ``block`` (9, n) holds x, then q_before, the pressure, f and τ_H in the first three columns
    of the rows below, and the two rows of ``earlier`` in those of its last two rows. Returns
    a new block (the state after the step, with the clipped command and q̇ in rows 5 and 6)
    and the outcome of :func:`step_into`; ``block`` is left as it is.
    """
    glove, work = unpack(packed), workspace()
    new = np.zeros((9, block.shape[1]))
    # ``earlier`` in (2, 3) arrays of their own: the rows of a block of six columns are not
    # contiguous, and step_into takes one layout (:func:`.jit.kernel`).
    earlier, new_earlier = np.empty((2, 3)), np.empty((2, 3))
    earlier[:, :] = block[7:, :3]
    regulator = new[9:]  # no rows, so no air: no gas state, no pneumatic constants
    state = (block[0], block[1, :3], block[2, :3], block[3, :3], block[4, :3], earlier, regulator)
    rows = (
        new[0],
        new[1, :3],
        new[2, :3],
        new[3, :3],
        new[4, :3],
        new[5, :3],
        new[6, :3],
        new_earlier,
        regulator,
    )
    limits = (decay, supply, rate, valid_low, valid_high)
    outcome = step_into(glove, work, state, rows, command, effort, limits, regulator)
    new[7:, :3] = new_earlier
    return new, outcome


@kernel(counted=False)
def run_rows(glove, work, state, new, commands, efforts, limits, air, record):
    """:func:`step_into` for every row of ``commands``, from ``state`` (updated), recorded."""
    applied, pressure, qdot, forces, torque, unknowns, status, iterations, residual, flags = (
        record[:10]
    )
    gas = record[10]
    for t in range(commands.shape[0]):
        outcome = step_into(glove, work, state, new, commands[t], efforts[t], limits, air)
        status[t], iterations[t], residual[t] = outcome[0], outcome[1], outcome[2]
        flags[t, 0], flags[t, 1], flags[t, 2], flags[t, 3] = outcome[3:]
        for k in range(state[0].size):
            state[0][k] = new[0][k]
        for k in range(3):
            state[1][k] = new[1][k]
            state[2][k] = new[2][k]
            state[3][k] = new[3][k]
            state[4][k] = new[4][k]
            state[5][0, k] = new[7][0, k]
            state[5][1, k] = new[7][1, k]
        for row in range(state[6].shape[0]):
            for k in range(3):
                state[6][row, k] = new[8][row, k]
                gas[t, row, k] = new[8][row, k]
        for k in range(new[0].size):
            unknowns[t, k] = new[0][k]
        for k in range(new[5].size):
            applied[t, k] = new[5][k]
        for k in range(3):
            pressure[t, k] = new[2][k]
            forces[t, k] = new[3][k]
            torque[t, k] = new[4][k]
            qdot[t, k] = new[6][k]


@kernel
def run_glove(packed, air, state, commands, efforts, decay, supply, rate, valid_low, valid_high):
    """:func:`step_into` for every row of ``commands`` (T, 3 or 6) and ``efforts`` (T, 3).

    ``air`` and ``state`` as :func:`step_into` takes them.

    Returns
    -------
    state : tuple of ndarray
        The state after the last step (new arrays).
    record : tuple of ndarray
        Per step: the clipped command (T, 3 or 6), the pressure, q̇, f, τ_H (T, 3) and the
        unknowns x (T, n); status, iterations, residual (T,); the flags of the outcome (T, 4);
        the air (T, GAS_ROWS, 3) behind valves, else (T, 0, 3).
    """
    glove, work = unpack(packed), workspace()
    steps, n = commands.shape[0], state[0].size
    current = (
        state[0].copy(),
        state[1].copy(),
        state[2].copy(),
        state[3].copy(),
        state[4].copy(),
        state[5].copy(),
        state[6].copy(),
    )
    record = (
        np.empty((steps, commands.shape[1])),
        np.empty((steps, 3)),
        np.empty((steps, 3)),
        np.empty((steps, 3)),
        np.empty((steps, 3)),
        np.empty((steps, n)),
        np.empty(steps, np.int64),
        np.empty(steps, np.int64),
        np.empty(steps),
        np.empty((steps, 4), np.bool_),
        np.empty((steps, state[6].shape[0], 3)),
    )
    limits = (decay, supply, rate, valid_low, valid_high)
    run_rows(glove, work, current, fresh(n, air), commands, efforts, limits, air, record)
    return current, record


@kernel(counted=False)
def step_rows(glove, fingers, work, states, new, commands, efforts, limits, air, outcomes):
    """:func:`step_into` for every glove of a batch (its row of each array) on its finger.

    ``fingers``: the rows of the gloves' finger constants, link half lengths (N, 3) and laws
    (N, 3, LAW_COLUMNS) (:func:`.constants.with_finger`).
    """
    finger_half_lengths, laws = fingers
    status, iterations, residual, flags = outcomes
    for r in range(commands.shape[0]):
        patient = with_finger(glove, finger_half_lengths[r], laws[r])
        state = (
            states[0][r],
            states[1][r],
            states[2][r],
            states[3][r],
            states[4][r],
            states[5][r],
            states[6][r],
        )
        row = (
            new[0][r],
            new[1][r],
            new[2][r],
            new[3][r],
            new[4][r],
            new[5][r],
            new[6][r],
            new[7][r],
            new[8][r],
        )
        outcome = step_into(patient, work, state, row, commands[r], efforts[r], limits, air)
        status[r], iterations[r], residual[r] = outcome[0], outcome[1], outcome[2]
        flags[r, 0], flags[r, 1], flags[r, 2], flags[r, 3] = outcome[3:]


@kernel
def step_gloves(
    packed,
    finger_half_lengths,
    laws,
    air,
    states,
    commands,
    efforts,
    decay,
    supply,
    rate,
    valid_low,
    valid_high,
):
    """:func:`step_into` for every glove of a batch: ``states`` of arrays with a leading N.

    Glove r is the exo-digit of ``packed`` on the finger of row r of ``finger_half_lengths``
    (N, 3), m, and ``laws`` (N, 3, LAW_COLUMNS) (eqs 11.1-11.3): what one glove of that
    finger's packed constants gives, bit for bit.

    Returns the new states, the clipped commands, q̇ (N, 3), status, iterations, residual (N,)
    and the flags (N, 4) of :func:`run_glove`. ``air`` and ``states`` (rows of what
    :func:`step_into` takes) give the actuation: behind valves with ``air``.
    """
    glove, work = unpack(packed), workspace()
    rows = commands.shape[0]
    new = fresh_rows(rows, states[0].shape[1], air)
    outcomes = (
        np.empty(rows, np.int64),
        np.empty(rows, np.int64),
        np.empty(rows),
        np.empty((rows, 4), np.bool_),
    )
    limits = (decay, supply, rate, valid_low, valid_high)
    fingers = (finger_half_lengths, laws)
    step_rows(glove, fingers, work, states, new, commands, efforts, limits, air, outcomes)
    status, iterations, residual, flags = outcomes
    state = (new[0], new[1], new[2], new[3], new[4], new[7], new[8])
    return state, new[5], new[6], status, iterations, residual, flags
