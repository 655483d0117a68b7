r"""The Yeoh material's axial stress and tangent modulus along the pure-shear path (eqs 21-23).

With the strain e = λ − 1, D = λ − 1/λ, S = λ + 1/λ (both without cancellation as e → 0) and
λ̃ = I1 − 3 = D², eq 23 (corrected, docs/spec/model.md §9) reads

.. math:: \sigma = 2\,D\,S\,(C_1 + 2C_2\tilde\lambda + 3C_3\tilde\lambda^2), \qquad
          \frac{d\sigma}{d\lambda} = 2\Bigl[(D'S + D^2/\lambda)\,W_1
          + 2\,D S\,D\,D'\,(2C_2 + 6C_3\tilde\lambda)\Bigr]

with W_1 = ∂W/∂I1 and D' = 1 + 1/λ². The one function works on floats and on arrays alike.
"""

from __future__ import annotations

from .jit import kernel


@kernel(forceinline=True)
def stress_and_slope(c1, c2, c3, strain):
    """σ (Pa) and dσ/dλ (Pa) at strain e = λ − 1, for Yeoh coefficients C1..C3 (Pa)."""
    inverse = 1.0 / (1.0 + strain)
    d = strain * (2.0 + strain) * inverse
    s = 2.0 + strain * strain * inverse
    excess = d * d
    twice_c2, thrice_c3 = 2.0 * c2, 3.0 * c3
    dw_di1 = c1 + excess * (twice_c2 + thrice_c3 * excess)
    ds = d * s
    d_slope = 1.0 + inverse * inverse
    stress = 2.0 * ds * dw_di1
    slope = 2.0 * (
        (d_slope * s + excess * inverse) * dw_di1
        + 2.0 * ds * d * d_slope * (twice_c2 + 2.0 * thrice_c3 * excess)
    )
    return stress, slope
