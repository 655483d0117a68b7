"""Damped Newton iteration for the coupled quasi-statics (MODEL.md §7, §11), one state or a batch.

The iteration uses the analytic Jacobian of :class:`.coupling.Evaluation`, starts from the
caller's guess (warm start) and backtracks along the Newton direction until the squared residual
norm decreases enough (Armijo, factor 1e-4). Trial states whose top fibre would compress below
λ = 1 + MIN_TOP_STRAIN are refused before evaluation, so no state leaves the domain where the
material law is defined. The iteration never raises and never returns NaN: a state that cannot
be improved keeps its last finite value and is reported as not converged.

Convergence is judged relative to the problem, so that it means the same for a glove a thousand
times smaller or larger than the default one: the residual against the size of the terms it is
made of (``RTOL``), or, where rounding keeps the residual from going lower, a Newton step below
``XTOL`` rad (quadratic convergence puts the root within a tiny fraction of it). Each state ends
with a :data:`STATUS` code and its message, as scipy's solvers do.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

from .coupling import Evaluation, solve3

RTOL = 1e-12
"""Converged when ‖F‖ ≤ RTOL · ‖|τ_s| + |B_R p| + |(J_R*)ᵀ f|‖ (the terms F is made of)."""
XTOL = 1e-12
"""Converged when the full Newton step is at most this, rad (rounding limits ‖F‖)."""
MAX_ITERATIONS = 60
"""Newton steps at most."""
MAX_HALVINGS = 40
"""Step halvings at most per Newton step."""
ARMIJO = 1e-4
"""Sufficient-decrease factor of the line search."""
MIN_TOP_STRAIN = -0.8
"""Lowest top-fibre strain a trial state may have (λ_top ≥ 0.2)."""

CONVERGED, CONVERGED_STEP, ITERATION_LIMIT, NO_DECREASE, NOT_FINITE = range(5)
STATUS = {
    CONVERGED: 'converged: the residual is within RTOL of the size of its terms',
    CONVERGED_STEP: 'converged: the Newton step fell below XTOL (the residual is at rounding '
    'level)',
    ITERATION_LIMIT: 'not converged: the iteration limit was reached',
    NO_DECREASE: 'not converged: the line search found no decrease of the residual',
    NOT_FINITE: 'not converged: the residual or the Newton step is not finite',
}
"""Status codes of a solve and what they mean (codes below ITERATION_LIMIT are converged)."""


@dataclass
class NewtonOutcome:
    """Final state of :func:`newton`: per element for a batch, plain values for one state."""

    q: list
    forces: list
    finger_torque: list
    residual: object
    iterations: object
    status: object
    final: Evaluation | None
    """The evaluation at ``q`` (one state only; None for a batch)."""


def _norm(residual):
    return (
        residual[0] * residual[0] + residual[1] * residual[1] + residual[2] * residual[2]
    ) ** 0.5


def newton(
    p,
    evaluate: Callable[..., Evaluation],
    ops,
    strain_per_angle: tuple,
    first: Evaluation,
) -> NewtonOutcome:
    """Solve F(q, p) = 0 from the state of ``first``, the evaluation at the start.

    Parameters
    ----------
    p : list of 3
        Pressures, Pa: floats, or 1-D arrays for a batch.
    evaluate : callable
        ``(q, p) -> Evaluation``.
    ops : backend of :mod:`._backend`
    strain_per_angle : tuple of 3
        H_k/ℓ̂_k: the top-fibre strain per radian of each joint, for the domain check.
    first : Evaluation
        The evaluation at the start (a warm start may re-price a previous solution's final
        evaluation, see :meth:`.Evaluation.at_pressure`).
    """
    evaluation = first
    q, residual = first.q, first.residual
    forces, finger_torque = first.forces, first.finger_torque
    norm = _norm(residual)
    status = ops.where(norm <= RTOL * first.scale, CONVERGED, ITERATION_LIMIT)
    status = ops.where(ops.isfinite(norm), status, NOT_FINITE)
    iterations = 0 * status
    active = status == ITERATION_LIMIT
    jacobian = evaluation.jacobian() if ops.any(active) else None
    for _ in range(MAX_ITERATIONS):
        if not ops.any(active):
            break
        step = solve3(jacobian, [-r for r in residual])
        size = _norm(step)
        usable = ops.isfinite(size)
        status = ops.where(active & ops.logical_not(usable), NOT_FINITE, status)
        active = active & usable
        small = active & (size <= XTOL)
        alpha = 1.0
        for _ in range(MAX_HALVINGS):
            trial = [q[0] + alpha * step[0], q[1] + alpha * step[1], q[2] + alpha * step[2]]
            allowed = (
                active
                & (trial[0] * strain_per_angle[0] >= MIN_TOP_STRAIN)
                & (trial[1] * strain_per_angle[1] >= MIN_TOP_STRAIN)
                & (trial[2] * strain_per_angle[2] >= MIN_TOP_STRAIN)
            )
            trial = ops.select(allowed, trial, q)
            candidate = evaluate(trial, p)
            candidate_norm = _norm(candidate.residual)
            # A step below XTOL is taken whole: at the root, rounding may not let F decrease.
            accepted = (
                allowed
                & (small | (candidate_norm <= (1.0 - ARMIJO * alpha) * norm))
                & ops.isfinite(candidate_norm)
            )
            pending = active & ops.logical_not(accepted)
            if not ops.any(pending):
                break
            alpha = ops.where(pending, 0.5 * alpha, alpha)
        status = ops.where(pending, NO_DECREASE, status)
        if ops.single_state and accepted:
            evaluation = candidate
        q = ops.select(accepted, trial, q)
        residual = ops.select(accepted, candidate.residual, residual)
        forces = ops.select(accepted, candidate.forces, forces)
        finger_torque = ops.select(accepted, candidate.finger_torque, finger_torque)
        norm = ops.where(accepted, candidate_norm, norm)
        iterations = iterations + ops.where(accepted, 1, 0)
        done = accepted & (norm <= RTOL * candidate.scale)
        status = ops.where(done, CONVERGED, ops.where(accepted & small, CONVERGED_STEP, status))
        active = status == ITERATION_LIMIT
        if ops.any(active):
            jacobian = ops.select(accepted, candidate.jacobian(), jacobian)
    return NewtonOutcome(
        q,
        forces,
        finger_torque,
        norm,
        iterations,
        status,
        evaluation if ops.single_state else None,
    )
