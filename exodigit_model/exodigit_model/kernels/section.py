r"""The cross-section's stress resultants by quadrature (eqs 13, 27; docs/spec/model.md §5, §12).

A fibre at height y above the bottom face has the strain e(y) = ε + y q/ℓ̂ (12.1; ε = λ_b − 1,
zero for an inextensible layer), and the section carries

.. math::

    M = \int_A \sigma\,y\,dA, \quad N = \int_A \sigma\,dA, \quad
    \frac{\partial M}{\partial q} = \int_A \sigma' \frac{y^2}{\hat\ell} dA, \quad
    \frac{\partial M}{\partial \varepsilon} = \int_A \sigma' y\,dA
    = \hat\ell\,\frac{\partial N}{\partial q}, \quad
    \frac{\partial N}{\partial \varepsilon} = \int_A \sigma' dA

each a weighted sum over the fixed Gauss-Legendre points of :class:`..section.SectionQuadrature`
(``GloveConstants.heights`` and ``weights``). τ_s = −M (eq 13).
"""

from __future__ import annotations

import numpy as np

from .jit import kernel
from .material import stress_and_slope


@kernel(counted=False)
def resultants(glove, k, q, strain):
    """(M, N, ∂M/∂q, ∂M/∂ε, ∂N/∂ε) of segment ``k`` at angle ``q`` and bottom strain ``strain``.

    Units: N·m, N, N·m/rad, N·m, N (∂N/∂q is ∂M/∂ε / ℓ̂).
    """
    c1, c2, c3 = glove.material[0], glove.material[1], glove.material[2]
    per_length = 1.0 / glove.arc_lengths[k]
    heights, weights = glove.heights, glove.weights
    moment = force = moment_slope = moment_rate = force_rate = 0.0
    for j in range(heights.shape[1]):
        y, w = heights[k, j], weights[k, j]
        y_per_length = y * per_length
        stress, slope = stress_and_slope(c1, c2, c3, strain + q * y_per_length)
        wy = w * y
        moment += stress * wy
        force += stress * w
        moment_slope += slope * wy * y_per_length
        moment_rate += slope * wy
        force_rate += slope * w
    return moment, force, moment_slope, moment_rate, force_rate


@kernel
def resisting_moments(glove, k, angles):
    """M(q) (N·m) and dM/dq (N·m/rad) of segment ``k`` at each of ``angles`` (1-D, rad)."""
    moment = np.empty(angles.size)
    slope = np.empty(angles.size)
    for j in range(angles.size):
        moment[j], _, slope[j], _, _ = resultants(glove, k, angles[j], 0.0)
    return moment, slope
