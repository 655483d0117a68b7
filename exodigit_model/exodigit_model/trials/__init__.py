"""Virtual patient trials without ROS: populations of patients to try a controller on.

A population (docs/populations.md) is a set of distributions over the patient parameters of
docs/spec/model.md §11, sampled reproducibly from a seed.

>>> from exodigit_model.trials import load_population
>>> patients = load_population('stroke_moderate').sample(100, seed=1)
>>> patients.arrays['stiffness'].shape
(100, 3)
"""

from .distributions import Distribution, Fixed, LogNormal, Normal, Uniform
from .populations import (
    PATIENT_FIELDS,
    POPULATIONS,
    Correlation,
    Patients,
    Population,
    load_population,
    population_file,
)

__all__ = [
    'PATIENT_FIELDS',
    'POPULATIONS',
    'Correlation',
    'Distribution',
    'Fixed',
    'LogNormal',
    'Normal',
    'Patients',
    'Population',
    'Uniform',
    'load_population',
    'population_file',
]
