r"""Cross-section of one half-bellow soft segment: pressure moment and resisting moment.

The section (Fig. 2) stands on its inextensible bottom face y = 0 and has three zones:
the base, 0 ≤ y ≤ b, full width 2R; the two side walls, b ≤ y ≤ b + h, width 2t; and the
half-annular arch, r0 ≤ r ≤ R = r0 + t, centred at height b + h. A fibre at height y stretches
by λ(y) = 1 + y q / ℓ̂ when the segment bends by q (eqs 24-26).

- Pressure side, eq 12: :math:`r_pA_p = \frac{\pi}{2}R^2(\frac{4R}{3\pi} + h + b)
  + 2R(\frac h2 + b)h`, the first moment about y = 0 of the region above the base inside the
  outer contour (docs/spec/model.md §4). τ_p = r_pA_p · p (eq 11).
- Structural side, eqs 13 and 27 without the Taylor truncation:
  :math:`M(q) = \int_A \sigma(\lambda(y))\,y\,dA`, τ_s = -M (docs/spec/model.md §5).
- Extensible segments (docs/spec/model.md §12): the bottom face stretches by λ_b, every fibre by
  λ(y) = λ_b + y q / ℓ̂ (12.1), and the section carries the resultants M(q, λ_b) and
  N(q, λ_b) = ∫ σ dA (12.2); the pressure pushes the end faces apart on A_p (12.3).

:class:`SectionQuadrature` turns :math:`\int_A g(y)\,dA` into a weighted sum over fixed
Gauss-Legendre points of the three zones. Every integrand depends on y alone, so the arch is
integrated in y against its width; the substitutions u = r0 sin θ and u = R sin θ (u = y − b − h)
make both pieces smooth, the sum converges geometrically, and the default 44 points per section
agree with adaptive 2-D quadrature to about 1e-14 relative.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import cache

import numpy as np
from numpy.typing import NDArray

from .params import Segment


def pressure_moment(segment: Segment) -> float:
    """r_p·A_p of eq 12 (outer radius R = r0 + t, as printed), m³."""
    r, h, b = segment.outer_radius, segment.wall_height, segment.base_thickness
    return (
        0.5 * math.pi * r * r * (4.0 * r / (3.0 * math.pi) + h + b) + 2.0 * r * (0.5 * h + b) * h
    )


def pressure_area(segment: Segment) -> float:
    """A_p of docs/spec/model.md (12.3): the area of eq 12's region the pressure acts on, m²."""
    r, h = segment.outer_radius, segment.wall_height
    return 0.5 * math.pi * r * r + 2.0 * r * h


@cache
def _legendre(order: int) -> tuple[NDArray, NDArray]:
    """Gauss-Legendre nodes and weights of ``order`` on [-1, 1], computed once (read-only)."""
    nodes, weights = np.polynomial.legendre.leggauss(order)
    nodes.flags.writeable = weights.flags.writeable = False
    return nodes, weights


def _gauss(order: int, low: float, high: float) -> tuple[NDArray, NDArray]:
    nodes, weights = _legendre(order)
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
    def of(cls, segment: Segment, order: int = 6, arch_order: int = 16) -> SectionQuadrature:
        """Gauss-Legendre rule for the three zones of ``segment`` (eq 27's three integrals).

        The half annulus has width 2(√(R² − u²) − √(r0² − u²)) at u = y − b − h < r0 and
        2√(R² − u²) above; u = r0 sin θ (θ in [0, π/2]) and u = R sin θ (θ in [asin(r0/R), π/2])
        remove the square-root ends. ``order`` points per rectangle, ``arch_order`` per piece.
        """
        r0, t = segment.inner_radius, segment.wall_thickness
        outer = segment.outer_radius
        h, b = segment.wall_height, segment.base_thickness
        y_base, w_base = _gauss(order, 0.0, b)
        y_wall, w_wall = _gauss(order, b, b + h)
        angle, w_angle = _gauss(arch_order, 0.0, 0.5 * math.pi)
        u_inner, cos_inner = r0 * np.sin(angle), np.cos(angle)
        w_inner = (
            w_angle * 2.0 * (np.sqrt(outer**2 - u_inner**2) - r0 * cos_inner) * r0 * cos_inner
        )
        angle, w_angle = _gauss(arch_order, math.asin(r0 / outer), 0.5 * math.pi)
        u_outer = outer * np.sin(angle)
        w_outer = w_angle * 2.0 * (outer * np.cos(angle)) ** 2
        return cls(
            heights=np.concatenate([y_base, y_wall, b + h + u_inner, b + h + u_outer]),
            weights=np.concatenate([2.0 * outer * w_base, 2.0 * t * w_wall, w_inner, w_outer]),
        )

    def integrate(self, integrand: NDArray) -> NDArray:
        """Σ_k w_k g_k over the last axis of ``integrand`` (values at :attr:`heights`)."""
        return integrand @ self.weights
