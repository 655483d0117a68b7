"""Damped Newton iteration for the coupled quasi-statics (docs/spec/model.md §7, §11, §12).

The iteration uses the analytic Jacobian of :func:`.statics.evaluate`, starts from the caller's
guess (warm start) and backtracks along the Newton direction until the squared residual norm
decreases enough (Armijo, factor ``ARMIJO``). Where a step cut the residual to ``REUSE`` of
what it was or less, the next step keeps the Jacobian it was taken with (a chord step: near the
root the Jacobian hardly changes over such a step, so the iteration still gains at least that
factor per step); a chord step whose line search fails is taken again with a fresh Jacobian.
The residual is what decides convergence, never the Jacobian, so the root is the one Newton
finds, to the same tolerance. Trial states that would compress a fibre below
``MIN_STRETCH`` (where the material law stops being meaningful) are never evaluated. The
iteration never raises and never returns NaN: a state that cannot be improved keeps its last
finite value and is reported as not converged.

Convergence is judged relative to the problem, so that it means the same for a glove a thousand
times smaller or larger than the default one: the residual against the size of the terms it is
made of (``RTOL``), or, where rounding keeps the residual from going lower, a Newton step below
``XTOL`` (quadratic convergence puts the root within a tiny fraction of it). Each solve ends
with a status code (:data:`exodigit_model.physics.solver.STATUS` says each in words), as
scipy's do.
"""

from __future__ import annotations

import math

from .jit import kernel
from .linear import solve
from .statics import jacobian_of, residual_of

RTOL = 1e-12
"""Converged when ‖F‖ ≤ RTOL · ‖|τ_s| + |B_R p| + |(J_R*)ᵀ f|‖ (the terms F is made of)."""
XTOL = 1e-12
"""Converged when the full Newton step is at most this (rad, or unit strain)."""
MAX_ITERATIONS = 60
"""Newton steps at most."""
MAX_HALVINGS = 40
"""Step halvings at most per Newton step."""
ARMIJO = 1e-4
"""Sufficient-decrease factor of the line search."""
REUSE = 1e-3
"""A step that leaves at most this share of the residual keeps its Jacobian for the next."""
MIN_STRETCH = 0.2
"""Lowest fibre stretch a trial state may have (the material law's domain, with margin)."""

CONVERGED, CONVERGED_STEP, ITERATION_LIMIT, NO_DECREASE, NOT_FINITE = range(5)
"""Status codes (codes below ITERATION_LIMIT are converged)."""


@kernel(counted=False, forceinline=True)
def allowed(glove, x):
    """Whether every segment's bottom face and top fibre keep a stretch ≥ MIN_STRETCH (12.1)."""
    strain_per_angle = glove.strain_per_angle
    for k in range(3):
        bottom = 1.0 + x[3 + k] if x.size == 6 else 1.0
        if bottom < MIN_STRETCH or bottom + x[k] * strain_per_angle[k] < MIN_STRETCH:
            return False
    return True


@kernel(counted=False, forceinline=True)
def norm(v):
    """Euclidean norm of a small vector."""
    total = 0.0
    for value in v:
        total += value * value
    return math.sqrt(total)


@kernel(counted=False, forceinline=True)
def newton(glove, work, x, pressure, free, motion, rate, forces, torque):
    """Solve the statics of :func:`.statics.evaluate` for ``x`` in place, from ``x``.

    ``work`` is the scratch (:mod:`.workspace`); ``free``, ``motion`` and ``rate`` describe the
    finger (:func:`.statics.evaluate`); ``forces`` and ``torque`` receive f (N) and τ_H (N·m)
    at the final ``x``.

    Returns
    -------
    status : int
        ``CONVERGED`` … ``NOT_FINITE``.
    iterations : int
        Steps taken (Newton and chord steps).
    residual : float
        Residual norm at the final ``x``, N·m.
    """
    n = x.size
    residual, trial_residual = work.residual[:n], work.trial_residual[:n]
    jacobian = work.jacobian[: n * n].reshape((n, n))
    trial, step = work.trial[:n], work.step[:n]
    trial_forces, trial_torque, matrix = work.trial_forces, work.trial_torque, work.matrix
    # One call site of residual_of and one of jacobian_of: LLVM inlines both, and every further
    # site would be one more copy of them to compile. Every evaluation is of ``trial``: x itself
    # (``at_x``: the start, and x again after a failed chord step) or a point of a line search.
    for k in range(n):
        trial[k] = x[k]
    at_x, started = True, False
    fresh = True  # whether the step is taken with the Jacobian at ``x``
    iterations = steps = halvings = 0
    scale = size_of_residual = step_size = alpha = trial_scale = trial_size = 0.0
    small = False
    while True:
        accepted = at_x
        if at_x or allowed(glove, trial):
            trial_scale = residual_of(
                glove,
                work,
                trial,
                pressure,
                free,
                motion,
                rate,
                trial_residual,
                trial_forces,
                trial_torque,
            )
            trial_size = norm(trial_residual)
            # A step below XTOL is taken whole: at the root, rounding may not let F decrease.
            accepted = at_x or (
                math.isfinite(trial_size)
                and (small or trial_size <= (1.0 - ARMIJO * alpha) * size_of_residual)
            )
        if not accepted:
            halvings += 1
            alpha *= 0.5
            if halvings < MAX_HALVINGS:
                for k in range(n):
                    trial[k] = x[k] + alpha * step[k]
                continue
            if fresh:
                return NO_DECREASE, iterations, size_of_residual
            # A chord step failed: x again, then the Jacobian at x (``work`` holds the last
            # trial's terms, so x's are computed again, the same numbers).
            at_x = True
            for k in range(n):
                trial[k] = x[k]
            continue
        # (loops: a slice copy would allocate, and this kernel may not)
        previous_size = size_of_residual
        for k in range(n):
            x[k] = trial[k]
            residual[k] = trial_residual[k]
        for k in range(3):
            forces[k] = trial_forces[k]
            torque[k] = trial_torque[k]
        scale, size_of_residual = trial_scale, trial_size
        if at_x:
            at_x, fresh = False, True
            if not started:
                started = True
                if not math.isfinite(size_of_residual):
                    return NOT_FINITE, 0, size_of_residual
                if size_of_residual <= RTOL * scale:
                    return CONVERGED, 0, size_of_residual
        else:
            iterations += 1
            if size_of_residual <= RTOL * scale:
                return CONVERGED, iterations, size_of_residual
            if small:
                return CONVERGED_STEP, iterations, size_of_residual
            fresh = size_of_residual > REUSE * previous_size
        if fresh:  # ``work`` holds the terms at x: the last evaluation was of x
            jacobian_of(glove, work, x, free, jacobian, forces)
        if steps == MAX_ITERATIONS:
            return ITERATION_LIMIT, iterations, size_of_residual
        steps += 1
        for k in range(n):
            trial_residual[k] = -residual[k]
        solve(jacobian, trial_residual, step, matrix)
        step_size = norm(step)
        small = step_size <= XTOL
        if not math.isfinite(step_size):
            if fresh:
                return NOT_FINITE, iterations, size_of_residual
            at_x = True  # a chord step: x again, with the Jacobian at x
            for k in range(n):
                trial[k] = x[k]
            continue
        alpha, halvings = 1.0, 0
        for k in range(n):
            trial[k] = x[k] + alpha * step[k]
