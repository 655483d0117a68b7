"""Damped Newton iteration for the coupled quasi-statics (MODEL.md §7), one state or a batch.

The iteration uses the analytic Jacobian of :func:`.coupling.equilibrium`, starts from the
caller's guess (warm start) and backtracks along the Newton direction until the squared residual
norm decreases enough (Armijo, factor 1e-4). Trial states whose top fibre would compress below
λ = 1 + MIN_TOP_STRAIN are refused before evaluation, so no state leaves the domain where the
material law is defined. The iteration never raises and never returns NaN: a state that cannot
be improved keeps its last finite value and is reported as not converged.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

from .coupling import Evaluation, solve3

RESIDUAL_TOLERANCE = 1e-13
"""Converged when the 2-norm of F(q, p) is at most this, N·m (≈ 1e-12 rad in angle)."""
MAX_ITERATIONS = 60
"""Newton steps at most."""
MAX_HALVINGS = 40
"""Step halvings at most per Newton step."""
ARMIJO = 1e-4
"""Sufficient-decrease factor of the line search."""
MIN_TOP_STRAIN = -0.8
"""Lowest top-fibre strain a trial state may have (λ_top ≥ 0.2)."""


@dataclass
class NewtonOutcome:
    """Final state of :func:`newton`: per element for a batch, plain values for one state."""

    q: list
    forces: list
    residual: object
    iterations: object
    converged: object
    final: Evaluation | None
    """The evaluation at ``q`` (one state only; None for a batch)."""


def _norm(residual):
    return (
        residual[0] * residual[0] + residual[1] * residual[1] + residual[2] * residual[2]
    ) ** 0.5


def newton(
    q,
    p,
    evaluate: Callable[..., Evaluation],
    ops,
    strain_per_angle: tuple,
    first: Evaluation | None = None,
) -> NewtonOutcome:
    """Solve F(q, p) = 0 from the start ``q``.

    Parameters
    ----------
    q, p : list of 3
        Start angles (rad) and pressures (Pa): floats, or 1-D arrays for a batch.
    evaluate : callable
        ``(q, p) -> Evaluation``.
    ops : backend of :mod:`._backend`
    strain_per_angle : tuple of 3
        H_k/ℓ̂_k: the top-fibre strain per radian of each joint, for the domain check.
    first : Evaluation, optional
        The evaluation at (q, p) if the caller has it already (a warm start from a previous
        solution, see :meth:`.Evaluation.at_pressure`).
    """
    evaluation = evaluate(q, p) if first is None else first
    residual, forces = evaluation.residual, evaluation.forces
    norm = _norm(residual)
    converged = norm <= RESIDUAL_TOLERANCE
    failed = ops.logical_not(ops.isfinite(norm))
    iterations = ops.where(converged, 0, 0)
    active = ops.logical_not(converged | failed)
    jacobian = evaluation.jacobian() if ops.any(active) else None
    for _ in range(MAX_ITERATIONS):
        if not ops.any(active):
            break
        step = solve3(jacobian, [-r for r in residual])
        usable = ops.isfinite(step[0] + step[1] + step[2])
        failed = failed | (active & ops.logical_not(usable))
        active = active & usable
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
            accepted = allowed & (candidate_norm <= (1.0 - ARMIJO * alpha) * norm)
            pending = active & ops.logical_not(accepted)
            if not ops.any(pending):
                break
            alpha = ops.where(pending, 0.5 * alpha, alpha)
        failed = failed | pending
        if ops.single_state and accepted:
            evaluation = candidate
        q = ops.select(accepted, trial, q)
        residual = ops.select(accepted, candidate.residual, residual)
        forces = ops.select(accepted, candidate.forces, forces)
        norm = ops.where(accepted, candidate_norm, norm)
        iterations = iterations + ops.where(accepted, 1, 0)
        converged = norm <= RESIDUAL_TOLERANCE
        active = ops.logical_not(converged | failed)
        if ops.any(active):
            jacobian = ops.select(accepted, candidate.jacobian(), jacobian)
    return NewtonOutcome(
        q, forces, norm, iterations, converged, evaluation if ops.single_state else None
    )
