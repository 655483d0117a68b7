"""Yeoh material along the pure-shear path (docs/spec/model.md §5, eqs 21-23 corrected)."""

import numpy as np
import pytest
from exodigit_model.physics.material import yeoh_energy
from exodigit_model.physics.material import yeoh_stress as model_stress
from model_reference import yeoh_stress

from exodigit_model import Material

FD_STEP = 1e-5
"""Central-difference step in λ."""
FD_RTOL = 1e-7
"""Finite difference against the analytic stress, relative to the largest |σ| on the path."""
FORMULA_RTOL = 1e-12
"""Same formula evaluated two ways (round-off only)."""

STRETCHES = np.linspace(0.7, 1.8, 111)
MATERIALS = [
    Material(c1=1.1e5, c2=2.0e4, c3=0.0),
    Material(c1=3.0e4, c2=0.0, c3=1.0e4),
    Material(c1=1.0e6, c2=-4.0e4, c3=2.5e3),
]


@pytest.mark.parametrize('material', MATERIALS)
def test_stress_is_stretch_times_energy_slope(material):
    # Pure shear, σ3 = 0 and incompressible: σ1 = λ dW/dλ along λ1 = λ, λ2 = 1, λ3 = 1/λ.
    slope = (
        yeoh_energy(material, STRETCHES + FD_STEP) - yeoh_energy(material, STRETCHES - FD_STEP)
    ) / (2.0 * FD_STEP)
    stress = model_stress(material, STRETCHES)
    scale = np.max(np.abs(stress))
    np.testing.assert_allclose(stress, STRETCHES * slope, rtol=0.0, atol=FD_RTOL * scale)


@pytest.mark.parametrize('material', MATERIALS)
def test_energy_is_eq_22_of_the_first_invariant(material):
    excess = STRETCHES**2 + STRETCHES**-2 + 1.0 - 3.0
    expected = material.c1 * excess + material.c2 * excess**2 + material.c3 * excess**3
    np.testing.assert_allclose(
        yeoh_energy(material, STRETCHES), expected, rtol=FORMULA_RTOL, atol=1e-12
    )


@pytest.mark.parametrize('material', MATERIALS)
def test_stress_equals_eq_21_with_corrected_eq_23(material):
    np.testing.assert_allclose(
        model_stress(material, STRETCHES),
        yeoh_stress(material, STRETCHES),
        rtol=FORMULA_RTOL,
        atol=FORMULA_RTOL * material.c1,
    )


def test_the_factors_2_and_3_of_eq_23_are_applied():
    # With only C2 (C3) the stress is 2 (3) times what the misprinted eq 23 would give.
    lam = 1.4
    excess = lam**2 + lam**-2 - 2.0
    shear = 2.0 * (lam**2 - lam**-2)
    c1 = 1e-9  # C1 must be positive; this small it does not show.
    only_c2 = model_stress(Material(c1=c1, c2=1.0e4), lam)
    only_c3 = model_stress(Material(c1=c1, c3=1.0e4), lam)
    assert only_c2 == pytest.approx(shear * 2.0 * 1.0e4 * excess, rel=1e-12)
    assert only_c3 == pytest.approx(shear * 3.0 * 1.0e4 * excess**2, rel=1e-12)


@pytest.mark.parametrize('material', MATERIALS)
def test_unstretched_material_carries_no_stress(material):
    assert model_stress(material, 1.0) == 0.0
    assert yeoh_energy(material, 1.0) == 0.0


def test_small_strain_modulus_is_8_c1():
    # σ ≈ 2 (4e) C1 for λ = 1 + e: the linear (Young's-modulus-like) slope is 8 C1.
    material = MATERIALS[0]
    for strain in (1e-6, -1e-9, 1e-12):
        assert model_stress(material, 1.0 + strain) == pytest.approx(
            8.0 * material.c1 * strain, rel=1e-3
        )


def test_stress_keeps_the_shape_of_its_input():
    grid = STRETCHES.reshape(37, 3)
    assert model_stress(MATERIALS[0], grid).shape == (37, 3)
    assert np.ndim(model_stress(MATERIALS[0], 1.2)) == 0
