r"""Yeoh third-order hyperelastic material in the segment wall (eqs 15-23, docs/spec/model.md §5).

The wall deforms in pure shear: principal stretches :math:`\lambda_1 = \lambda` (axial),
:math:`\lambda_2 = 1` (circumferential, eq 18's assumption) and :math:`\lambda_3 = 1/\lambda`
(incompressibility, eq 19), with zero radial stress. Then

.. math::

    \tilde\lambda = I_1 - 3 = \lambda^2 + \lambda^{-2} - 2, \qquad
    W = C_1\tilde\lambda + C_2\tilde\lambda^2 + C_3\tilde\lambda^3 \quad (22)

.. math::

    \sigma(\lambda) = 2\,(\lambda^2 - \lambda^{-2})\,
    \bigl(C_1 + 2C_2\tilde\lambda + 3C_3\tilde\lambda^2\bigr) \quad (21, 23)

Eq 23 as printed drops the factors 2 and 3 of :math:`\partial W/\partial I_1`
(docs/spec/model.md §9).
All functions take stretches as floats or arrays of any shape and return the same shape.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..kernels.material import stress_and_slope
from .params import Material


def _shear_terms(strain: ArrayLike) -> tuple[NDArray, NDArray, NDArray]:
    """λ, D = λ - 1/λ and S = λ + 1/λ from the strain e = λ - 1, without cancellation at e → 0."""
    e = np.asarray(strain, dtype=float)
    lam = 1.0 + e
    return lam, e * (2.0 + e) / lam, 2.0 + e * e / lam


def first_invariant_excess(stretch: ArrayLike) -> NDArray[np.float64]:
    """λ̃ = I1 - 3 = λ² + λ⁻² - 2 = (λ - 1/λ)² on the pure-shear path (eq 16, λ2 = 1, λ3 = 1/λ)."""
    _, d, _ = _shear_terms(np.asarray(stretch, dtype=float) - 1.0)
    return d * d


def yeoh_energy(material: Material, stretch: ArrayLike) -> NDArray[np.float64]:
    """Strain energy density W(λ) of eq 22 along the pure-shear path, J/m³."""
    excess = first_invariant_excess(stretch)
    return excess * (material.c1 + excess * (material.c2 + excess * material.c3))


def stress_of_strain(material: Material, strain: ArrayLike) -> NDArray[np.float64]:
    """Axial Cauchy stress σ at strain e = λ - 1, Pa (eq 23 corrected; exact as e → 0)."""
    return stress_and_slope_of_strain(material, strain)[0]


def stress_and_slope_of_strain(material: Material, strain: ArrayLike) -> tuple[NDArray, NDArray]:
    """σ and dσ/dλ at strain e = λ - 1, Pa (:func:`.kernels.material.stress_and_slope`)."""
    e = np.asarray(strain, dtype=float)
    stress, slope = stress_and_slope(material.c1, material.c2, material.c3, e.ravel())
    return stress.reshape(e.shape), slope.reshape(e.shape)


def yeoh_stress(material: Material, stretch: ArrayLike) -> NDArray[np.float64]:
    """Axial Cauchy stress σ(λ) of eqs 21-23 (corrected), Pa; zero at λ = 1."""
    return stress_of_strain(material, np.asarray(stretch, dtype=float) - 1.0)
