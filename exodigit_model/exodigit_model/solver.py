"""Damped Newton iteration for the coupled quasi-statics (MODEL.md §7, §11), one state or a batch.

The iteration uses the analytic Jacobian of the evaluation (:class:`.coupling.Evaluation` for
the joint angles, :class:`.extensible.ExtensibleEvaluation` for angles and bottom-face strains),
starts from the caller's guess (warm start) and backtracks along the Newton direction until the
squared residual norm decreases enough (Armijo, factor 1e-4). Trial states the caller's
``allowed`` refuses (a fibre compressed below λ = 0.2) are never evaluated, so no state leaves
the domain where the material law is defined. The iteration never raises and never returns
NaN: a state that cannot be improved keeps its last finite value and is reported as not
converged.

Convergence is judged relative to the problem, so that it means the same for a glove a thousand
times smaller or larger than the default one: the residual against the size of the terms it is
made of (``RTOL``), or, where rounding keeps the residual from going lower, a Newton step below
``XTOL`` rad (quadratic convergence puts the root within a tiny fraction of it). Each state ends
with a :data:`STATUS` code and its message, as scipy's solvers do.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

from .coupling import Evaluation

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
    return sum(r * r for r in residual) ** 0.5


def newton(
    p,
    evaluate: Callable[..., Evaluation],
    ops,
    first: Evaluation,
    *,
    linear_solve: Callable,
    allowed: Callable,
) -> NewtonOutcome:
    """Solve F(x, p) = 0 from the state of ``first``, the evaluation at the start.

    Parameters
    ----------
    p : list of 3
        Pressures, Pa: floats, or 1-D arrays for a batch.
    evaluate : callable
        ``(x, p) -> evaluation`` with ``x``, ``residual``, ``scale``, ``forces``,
        ``finger_torque`` and ``jacobian()`` (:class:`.coupling.Evaluation`, the joint angles,
        or :class:`.extensible.ExtensibleEvaluation`, angles and bottom strains).
    ops : backend of :mod:`._backend`
    first : evaluation
        The evaluation at the start (a warm start may re-price a previous solution's final
        evaluation, see :meth:`.Evaluation.at_pressure`).
    linear_solve : callable
        ``(jacobian, rhs) -> step`` for the evaluation's nested Jacobian.
    allowed : callable
        ``x -> bool (or mask)``: whether a trial state lies where the material law is defined.
    """
    evaluation = first
    q, residual = first.x, first.residual
    size_of_x = len(q)
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
        step = linear_solve(jacobian, [-r for r in residual])
        size = _norm(step)
        usable = ops.isfinite(size)
        status = ops.where(active & ops.logical_not(usable), NOT_FINITE, status)
        active = active & usable
        small = active & (size <= XTOL)
        alpha = 1.0
        for _ in range(MAX_HALVINGS):
            trial = [q[k] + alpha * step[k] for k in range(size_of_x)]
            inside = active & allowed(trial)
            trial = ops.select(inside, trial, q)
            candidate = evaluate(trial, p)
            candidate_norm = _norm(candidate.residual)
            # A step below XTOL is taken whole: at the root, rounding may not let F decrease.
            accepted = (
                inside
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
