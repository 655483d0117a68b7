"""A trial's metrics over its patients: percentiles and the worst patients, ready for JSON.

docs/trials.md, "Aggregates". Every column of :class:`~.metrics.PatientMetrics` (each joint of a
per-joint metric, and its worst joint) gets its mean, its percentiles over the patients and the
patients who fared worst by it; everything is a plain ``dict``/``list``/``float``/``int``, so
``json.dumps`` takes it as it is.

>>> import numpy as np
>>> from exodigit_model.trials import MetricAccumulator, summarize
>>> metrics = MetricAccumulator(3)
>>> metrics.update(q=np.zeros((3, 3)), target=np.zeros(3), forces=np.arange(9.0).reshape(3, 3),
...                pressure=np.zeros((3, 3)), limited=False, solver_warning=False,
...                outside_model=False)
>>> summary = summarize(metrics.result(), worst=1)
>>> summary['metrics']['peak_force_n']['worst']
[{'patient': 2, 'value': 8.0}]
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np
from numpy.typing import NDArray

from .metrics import METRICS, Metric, PatientMetrics

DEFAULT_PERCENTILES = (1.0, 5.0, 50.0, 95.0, 99.0)
"""Percentiles reported by default, %."""

DEFAULT_WORST = 5
"""Worst patients listed per column by default."""


def summarize(
    metrics: PatientMetrics,
    *,
    percentiles: Sequence[float] = DEFAULT_PERCENTILES,
    worst: int = DEFAULT_WORST,
) -> dict[str, Any]:
    """The metrics' distribution over the patients, as plain values for JSON.

    Parameters
    ----------
    metrics : PatientMetrics
        The per-patient metrics of a session.
    percentiles : sequence of float
        Percentiles to report, each in [0, 100] (linear interpolation between patients, numpy's
        default).
    worst : int
        How many of the worst patients to list per column (>= 0; all when fewer patients).

    Returns
    -------
    dict
        ``patients``, ``steps``, ``duration_s``, ``force_limit_n``, and ``metrics``: per column
        (``name.<joint>``, and ``name`` alone for a per-joint metric's worst joint, see
        :meth:`~.metrics.PatientMetrics.column`) its ``unit``, ``mean``, ``percentiles``
        (``{'p1': …, 'p50': …}``) and, where the metric has a worse side, ``worst``: the
        patients (index into the population's sample) with their values, worst first; ties in
        the order of the patients.

    Raises
    ------
    ValueError
        For a percentile outside [0, 100] or a count of worst patients < 0.
    """
    levels = [float(level) for level in percentiles]
    if not all(0.0 <= level <= 100.0 for level in levels):
        raise ValueError(f'percentiles = {percentiles!r}: each must lie within [0, 100]')
    if isinstance(worst, bool) or not isinstance(worst, int) or worst < 0:
        raise ValueError(f'worst = {worst!r}: must be a whole number >= 0')
    summary = {}
    for metric in METRICS:
        for name in _summarized_columns(metric):
            values = metrics.column(name)
            entry = {
                'unit': metric.unit,
                'mean': float(values.mean()),
                'percentiles': {
                    f'p{level:g}': float(value)
                    for level, value in zip(levels, np.percentile(values, levels), strict=True)
                },
            }
            if metric.worse is not None:
                entry['worst'] = worst_patients(values, metric.worse, worst)
            summary[name] = entry
    return {
        'patients': len(metrics),
        'steps': metrics.steps,
        'duration_s': metrics.duration,
        'force_limit_n': metrics.settings.force_limit,
        'metrics': summary,
    }


def worst_patients(values: NDArray[np.float64], worse: str, count: int) -> list[dict[str, Any]]:
    """The ``count`` patients with the highest (``worse='high'``) or lowest values, worst first.

    Ties keep the patients' order. Each is ``{'patient': index, 'value': value}``.
    """
    order = np.argsort(-values if worse == 'high' else values, kind='stable')[:count]
    return [{'patient': int(i), 'value': float(values[i])} for i in order]


def _summarized_columns(metric: Metric) -> tuple[str, ...]:
    """A metric's columns, and for a per-joint metric with a worse side its worst joint."""
    if metric.per_joint and metric.worse is not None:
        return (metric.name, *metric.columns)
    return metric.columns
