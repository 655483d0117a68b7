"""Small dense linear algebra for the kernels: 3×3 triangular systems and n×n solves."""

from __future__ import annotations

import numpy as np

from .jit import kernel


@kernel(counted=False, forceinline=True)
def transpose_solve(lower, rhs, x):
    """Solve Lᵀ x = rhs for a lower-triangular 3×3 L (back substitution), into ``x``."""
    x[2] = rhs[2] / lower[2, 2]
    x[1] = (rhs[1] - lower[2, 1] * x[2]) / lower[1, 1]
    x[0] = (rhs[0] - lower[1, 0] * x[1] - lower[2, 0] * x[2]) / lower[0, 0]


@kernel(counted=False, forceinline=True)
def transpose_product(lower, v, x):
    """Lᵀ v for a lower-triangular 3×3 L, into ``x``."""
    x[0] = lower[0, 0] * v[0] + lower[1, 0] * v[1] + lower[2, 0] * v[2]
    x[1] = lower[1, 1] * v[1] + lower[2, 1] * v[2]
    x[2] = lower[2, 2] * v[2]


@kernel(counted=False, forceinline=True)
def solve(a, b, x, scratch):
    """Solve A x = b into ``x`` for a square A (3×3 by cofactors, larger by pivoted elimination).

    ``scratch`` (at least n² numbers) takes the elimination's copy of A. A singular A gives a
    non-finite x (never an exception): the caller judges it.
    """
    n = b.size
    if n == 3:
        c00 = a[1, 1] * a[2, 2] - a[1, 2] * a[2, 1]
        c01 = a[1, 2] * a[2, 0] - a[1, 0] * a[2, 2]
        c02 = a[1, 0] * a[2, 1] - a[1, 1] * a[2, 0]
        determinant = a[0, 0] * c00 + a[0, 1] * c01 + a[0, 2] * c02
        if determinant == 0.0:
            x[:] = np.nan
            return
        inv_det = 1.0 / determinant
        c10 = a[0, 2] * a[2, 1] - a[0, 1] * a[2, 2]
        c11 = a[0, 0] * a[2, 2] - a[0, 2] * a[2, 0]
        c12 = a[0, 1] * a[2, 0] - a[0, 0] * a[2, 1]
        c20 = a[0, 1] * a[1, 2] - a[0, 2] * a[1, 1]
        c21 = a[0, 2] * a[1, 0] - a[0, 0] * a[1, 2]
        c22 = a[0, 0] * a[1, 1] - a[0, 1] * a[1, 0]
        x[0] = (c00 * b[0] + c10 * b[1] + c20 * b[2]) * inv_det
        x[1] = (c01 * b[0] + c11 * b[1] + c21 * b[2]) * inv_det
        x[2] = (c02 * b[0] + c12 * b[1] + c22 * b[2]) * inv_det
        return
    m = scratch[: n * n].reshape((n, n))
    for row in range(n):
        x[row] = b[row]
        for col in range(n):
            m[row, col] = a[row, col]
    for col in range(n):
        pivot = col
        for row in range(col + 1, n):
            if abs(m[row, col]) > abs(m[pivot, col]):
                pivot = row
        if m[pivot, col] == 0.0:
            x[:] = np.nan
            return
        if pivot != col:
            for j in range(n):
                m[col, j], m[pivot, j] = m[pivot, j], m[col, j]
            x[col], x[pivot] = x[pivot], x[col]
        for row in range(col + 1, n):
            factor = m[row, col] / m[col, col]
            for j in range(col, n):
                m[row, j] -= factor * m[col, j]
            x[row] -= factor * x[col]
    for row in range(n - 1, -1, -1):
        total = x[row]
        for j in range(row + 1, n):
            total -= m[row, j] * x[j]
        x[row] = total / m[row, row]
