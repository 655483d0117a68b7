"""Virtual patient trials without ROS: populations, session protocols, metrics and rules.

A population (docs/populations.md) is a set of distributions over the patient parameters of
docs/spec/model.md §11, sampled reproducibly from a seed. A session protocol gives the duration,
the rate and the joint targets of a session; the metrics of each patient are accumulated step by
step over the whole batch, summarized over the patients, and judged by a pass/fail rule
(docs/trials.md).

>>> from exodigit_model.trials import load_population
>>> patients = load_population('stroke_moderate').sample(100, seed=1)
>>> patients.arrays['stiffness'].shape
(100, 3)
"""

from ..physics.distributions import Distribution, Fixed, LogNormal, Normal, Uniform
from ..physics.populations import (
    PATIENT_FIELDS,
    POPULATIONS,
    Correlation,
    Patients,
    Population,
    load_population,
    population_file,
)
from .aggregates import DEFAULT_PERCENTILES, DEFAULT_WORST, summarize, worst_patients
from .metrics import (
    DEFAULT_FORCE_LIMIT,
    METRIC_NAMES,
    METRICS,
    Metric,
    MetricAccumulator,
    MetricSettings,
    PatientMetrics,
    column_names,
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
from .rules import COMPARISONS, Rule, RuleResult
from .spec import CONTROLLER_KINDS, DEFAULT_SHARD_SIZE, ControllerSpec, TrialSpec
from .trial import (
    Engine,
    LocalEngine,
    PatientRecord,
    TrialResult,
    record_patient,
    run_shard,
    run_trial,
    shard_bounds,
    shard_patients,
    shard_seeds,
)

__all__ = [
    'COMPARISONS',
    'CONTROLLER_KINDS',
    'DEFAULT_FORCE_LIMIT',
    'DEFAULT_PERCENTILES',
    'DEFAULT_SHARD_SIZE',
    'DEFAULT_WORST',
    'FUNCTIONAL_FLEXION',
    'FUNCTIONAL_RANGE',
    'METRICS',
    'METRIC_NAMES',
    'PATIENT_FIELDS',
    'POPULATIONS',
    'PROTOCOLS',
    'ContinuousPassiveMotion',
    'ControllerSpec',
    'Correlation',
    'Distribution',
    'Engine',
    'Fixed',
    'GraspRelease',
    'LocalEngine',
    'LogNormal',
    'Metric',
    'MetricAccumulator',
    'MetricSettings',
    'Normal',
    'PatientMetrics',
    'PatientRecord',
    'Patients',
    'Population',
    'Rule',
    'RuleResult',
    'SessionProtocol',
    'Staircase',
    'TrialResult',
    'TrialSpec',
    'Uniform',
    'column_names',
    'flex_extend',
    'load_population',
    'make_protocol',
    'population_file',
    'record_patient',
    'run_shard',
    'run_trial',
    'shard_bounds',
    'shard_patients',
    'shard_seeds',
    'summarize',
    'worst_patients',
]
