r"""Cross-section of one half-bellow soft segment: pressure moment and resisting moment.

The section (Fig. 2) stands on its inextensible bottom face y = 0 and has three zones:
the base, 0 ≤ y ≤ b, full width 2R; the two side walls, b ≤ y ≤ b + h, width 2t; and the
half-annular arch, r0 ≤ r ≤ R = r0 + t, centred at height b + h. A fibre at height y stretches
by λ(y) = 1 + y q / ℓ̂ when the segment bends by q (eqs 24-26).

- Pressure side, eq 12: :math:`r_pA_p = \frac{\pi}{2}R^2(\frac{4R}{3\pi} + h + b)
  + 2R(\frac h2 + b)h`, the first moment about y = 0 of the region above the base inside the
  outer contour (MODEL.md §4). τ_p = r_pA_p · p (eq 11).
- Structural side, eqs 13 and 27 without the Taylor truncation:
  :math:`M(q) = \int_A \sigma(\lambda(y))\,y\,dA`, τ_s = -M (MODEL.md §5).

:class:`SectionQuadrature` turns :math:`\int_A g(y)\,dA` into a weighted sum over fixed
Gauss-Legendre points of the three zones; the integrand is smooth, so the sum converges
geometrically and reaches 1e-13 relative with the default orders.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .material import stress_of_strain, stress_slope_of_strain
from .params import Material, Segment


def pressure_moment(segment: Segment) -> float:
    """r_p·A_p of eq 12 (outer radius R = r0 + t, as printed), m³."""
    r, h, b = segment.outer_radius, segment.wall_height, segment.base_thickness
    return (
        0.5 * math.pi * r * r * (4.0 * r / (3.0 * math.pi) + h + b) + 2.0 * r * (0.5 * h + b) * h
    )


def _gauss(order: int, low: float, high: float) -> tuple[NDArray, NDArray]:
    nodes, weights = np.polynomial.legendre.leggauss(order)
    half = 0.5 * (high - low)
    return low + half * (nodes + 1.0), half * weights


@dataclass(frozen=True)
class SectionQuadrature:
    """Points y_k and area weights w_k with ∫_A g(y) dA ≈ Σ_k w_k g(y_k) over the section.

    Attributes
    ----------
    heights : ndarray
        y_k, fibre heights above the bottom face, m.
    weights : ndarray
        w_k, area weights, m².
    """

    heights: NDArray[np.float64]
    weights: NDArray[np.float64]

    @classmethod
    def of(
        cls, segment: Segment, order: int = 12, radial_order: int = 8, angular_order: int = 28
    ) -> SectionQuadrature:
        """Gauss-Legendre rule for the three zones of ``segment`` (eq 27's three integrals)."""
        r0, t = segment.inner_radius, segment.wall_thickness
        h, b = segment.wall_height, segment.base_thickness
        y_base, w_base = _gauss(order, 0.0, b)
        y_wall, w_wall = _gauss(order, b, b + h)
        radius, w_radius = _gauss(radial_order, r0, r0 + t)
        angle, w_angle = _gauss(angular_order, 0.0, 0.5 * math.pi)
        y_arch = b + h + np.outer(radius, np.sin(angle))
        # Two quarter annuli (eq 27's factor 2); the polar area element is r dr dφ.
        w_arch = 2.0 * np.outer(w_radius * radius, w_angle)
        return cls(
            heights=np.concatenate([y_base, y_wall, y_arch.ravel()]),
            weights=np.concatenate(
                [2.0 * segment.outer_radius * w_base, 2.0 * t * w_wall, w_arch.ravel()]
            ),
        )

    def integrate(self, integrand: NDArray) -> NDArray:
        """Σ_k w_k g_k over the last axis of ``integrand`` (values at :attr:`heights`)."""
        return integrand @ self.weights


def resisting_moment(
    material: Material, segment: Segment, angle: ArrayLike, rule: SectionQuadrature
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """M(q) = ∫_A σ(1 + y q/ℓ̂) y dA and dM/dq by quadrature (eq 27, MODEL.md §5).

    Parameters
    ----------
    material : Material
    segment : Segment
    angle : array_like
        Bending angles q, rad, any shape.
    rule : SectionQuadrature
        Quadrature of ``segment``'s cross-section.

    Returns
    -------
    moment, slope : ndarray
        M in N·m and dM/dq in N·m/rad, shaped like ``angle``. τ_s = -M.
    """
    q = np.asarray(angle, dtype=float)
    y = rule.heights
    strain = q[..., None] * (y / segment.arc_length)
    moment = rule.integrate(stress_of_strain(material, strain) * y)
    slope = rule.integrate(stress_slope_of_strain(material, strain) * (y * y / segment.arc_length))
    return moment, slope
