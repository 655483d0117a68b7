"""Virtual patient trials without ROS: populations of patients and session protocols.

A population (docs/populations.md) is a set of distributions over the patient parameters of
docs/spec/model.md §11, sampled reproducibly from a seed. A session protocol gives the duration,
the rate and the joint targets of a session.

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
from .protocols import (
    FUNCTIONAL_FLEXION,
    FUNCTIONAL_RANGE,
    PROTOCOLS,
    ContinuousPassiveMotion,
    GraspRelease,
    SessionProtocol,
    Staircase,
    flex_extend,
    make_protocol,
)

__all__ = [
    'FUNCTIONAL_FLEXION',
    'FUNCTIONAL_RANGE',
    'PATIENT_FIELDS',
    'POPULATIONS',
    'PROTOCOLS',
    'ContinuousPassiveMotion',
    'Correlation',
    'Distribution',
    'Fixed',
    'GraspRelease',
    'LogNormal',
    'Normal',
    'Patients',
    'Population',
    'SessionProtocol',
    'Staircase',
    'Uniform',
    'flex_extend',
    'load_population',
    'make_protocol',
    'population_file',
]
