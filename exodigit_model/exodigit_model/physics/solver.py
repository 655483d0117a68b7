"""What a solve's status means (the damped Newton iteration itself is :mod:`.kernels.newton`).

Every forward solve ends with one of these codes, as scipy's solvers do; codes below
``ITERATION_LIMIT`` are converged. The tolerances and limits live beside the iteration
(``RTOL``, ``XTOL``, ``MAX_ITERATIONS``, ``MAX_HALVINGS``, ``ARMIJO``, ``MIN_STRETCH``).
"""

from __future__ import annotations

from ..kernels.newton import (
    ARMIJO,
    CONVERGED,
    CONVERGED_STEP,
    ITERATION_LIMIT,
    MAX_HALVINGS,
    MAX_ITERATIONS,
    MIN_STRETCH,
    NO_DECREASE,
    NOT_FINITE,
    RTOL,
    XTOL,
)

__all__ = [
    'ARMIJO',
    'CONVERGED',
    'CONVERGED_STEP',
    'ITERATION_LIMIT',
    'MAX_HALVINGS',
    'MAX_ITERATIONS',
    'MIN_STRETCH',
    'NOT_FINITE',
    'NO_DECREASE',
    'RTOL',
    'STATUS',
    'XTOL',
]

STATUS = {
    CONVERGED: 'converged: the residual is within RTOL of the size of its terms',
    CONVERGED_STEP: 'converged: the Newton step fell below XTOL (the residual is at rounding '
    'level)',
    ITERATION_LIMIT: 'not converged: the iteration limit was reached',
    NO_DECREASE: 'not converged: the line search found no decrease of the residual',
    NOT_FINITE: 'not converged: the residual or the Newton step is not finite',
}
"""Status codes of a solve and what they mean (codes below ITERATION_LIMIT are converged)."""
