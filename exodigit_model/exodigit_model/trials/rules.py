"""The pass/fail rule of a trial, for CI: ``peak_force_n <= 5 for 99%`` (docs/trials.md, "Rules").

A rule is ``METRIC[.JOINT] OP THRESHOLD for SHARE%``: a metric of :data:`~.metrics.METRICS`
(optionally one joint of a per-joint metric), a comparison (``<=``, ``<``, ``>=``, ``>``), a
threshold in the metric's unit and the share of the patients for whom the comparison must hold.
A per-joint metric named without a joint must hold at every joint of the patient (so its worst
joint for the rule decides). :meth:`Rule.evaluate` gives a :class:`RuleResult` with ``passed``,
``status`` and a ``message``.

>>> import numpy as np
>>> from exodigit_model.trials import MetricAccumulator, Rule
>>> metrics = MetricAccumulator(4)
>>> metrics.update(q=np.zeros((4, 3)), target=np.zeros(3), forces=np.full((4, 3), 2.0),
...                pressure=np.zeros((4, 3)), limited=False, solver_warning=False,
...                outside_model=False)
>>> result = Rule.parse('peak_force_n < 2 for 50%').evaluate(metrics.result())
>>> result.passed, result.status
(False, 1)
>>> print(result.message)
failed: peak_force_n < 2 held for 0 % of 4 patients (0), required 50 %; worst patient 0: 2 N (mcp)
"""

from __future__ import annotations

import math
import operator
import re
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from fractions import Fraction
from types import MappingProxyType

import numpy as np

from ..physics.params import JOINT_NAMES
from .metrics import METRIC_NAMES, PatientMetrics

COMPARISONS: Mapping[str, Callable] = MappingProxyType(
    {'<=': operator.le, '<': operator.lt, '>=': operator.ge, '>': operator.gt}
)
"""The comparisons a rule may use."""

FORM = "METRIC[.JOINT] OP THRESHOLD for SHARE% (e.g. 'peak_force_n <= 5 for 99%')"
"""The form of a rule, for messages."""

_RULE = re.compile(r'(?P<condition>.*?)\s+for\s+(?P<share>.*)')
_CONDITION = re.compile(r'(?P<subject>[^<>=!\s]+)\s*(?P<comparison>[<>=!]+)\s*(?P<threshold>\S+)')
_SHARE = re.compile(r'(?P<percent>[^%\s]+)\s*%')


@dataclass(frozen=True)
class Rule:
    """The condition a share of the patients must meet.

    Attributes
    ----------
    metric : str
        A metric of :data:`~.metrics.METRICS`.
    comparison : str
        One of :data:`COMPARISONS`.
    threshold : float
        Compared with the metric, in its unit.
    percent : float
        The share of the patients that must meet the condition, % (0 < percent <= 100).
    joint : str or None
        One joint (``mcp``, ``pip``, ``dip``) of a per-joint metric; None: every joint.

    Raises
    ------
    ValueError
        For an unknown metric (the message lists them) or joint, a joint of a metric that has
        none, an unknown comparison, a threshold that is not finite, or a share out of range.
    """

    metric: str
    comparison: str
    threshold: float
    percent: float
    joint: str | None = None

    def __post_init__(self) -> None:
        """Refuse what cannot be evaluated, saying what is wrong."""
        metric = METRIC_NAMES.get(self.metric)
        if metric is None:
            raise ValueError(f'unknown metric {self.metric!r} (known: {", ".join(METRIC_NAMES)})')
        if self.joint is not None and not metric.per_joint:
            raise ValueError(
                f'{self.metric} has one value per patient, not one per joint: drop ".{self.joint}"'
            )
        if self.joint is not None and self.joint not in JOINT_NAMES:
            raise ValueError(f'unknown joint {self.joint!r} (known: {", ".join(JOINT_NAMES)})')
        if self.comparison not in COMPARISONS:
            raise ValueError(
                f'comparison {self.comparison!r}: must be one of {", ".join(COMPARISONS)}'
            )
        for name in ('threshold', 'percent'):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, int | float):
                raise ValueError(f'{name} = {value!r}: must be a number')
            if not math.isfinite(value):
                raise ValueError(f'{name} = {value!r}: must be finite')
            object.__setattr__(self, name, float(value))
        if not 0.0 < self.percent <= 100.0:
            raise ValueError(f'share {self.percent:g}%: must be above 0 % and at most 100 %')

    @classmethod
    def parse(cls, text: str) -> Rule:
        """The rule written as ``METRIC[.JOINT] OP THRESHOLD for SHARE%``.

        Raises
        ------
        ValueError
            Naming the rule and what is wrong with it.
        """
        if not isinstance(text, str):
            raise ValueError(f'rule {text!r}: must be text of the form {FORM}')
        try:
            rule = _RULE.fullmatch(text.strip())
            if rule is None:
                raise ValueError("no 'for SHARE%': the share of patients that must pass")
            condition = _CONDITION.fullmatch(rule['condition'])
            if condition is None:
                raise ValueError(
                    f'condition {rule["condition"]!r}: must be METRIC[.JOINT] OP THRESHOLD, '
                    f'OP one of {", ".join(COMPARISONS)}'
                )
            share = _SHARE.fullmatch(rule['share'])
            if share is None:
                raise ValueError(f'share {rule["share"]!r}: must be a percentage such as 99%')
            metric, _, joint = condition['subject'].partition('.')
            return cls(
                metric,
                condition['comparison'],
                _number('threshold', condition['threshold']),
                _number('share', share['percent']),
                joint or None,
            )
        except ValueError as error:
            raise ValueError(f'rule {text!r}: {error}; form: {FORM}') from None

    @property
    def subject(self) -> str:
        """``metric`` or ``metric.joint``."""
        return self.metric if self.joint is None else f'{self.metric}.{self.joint}'

    @property
    def condition(self) -> str:
        """The comparison part, ``metric[.joint] op threshold``."""
        return f'{self.subject} {self.comparison} {self.threshold:g}'

    def __str__(self) -> str:
        """The rule as :meth:`parse` reads it."""
        return f'{self.condition} for {self.percent:g}%'

    def evaluate(self, metrics: PatientMetrics) -> RuleResult:
        """Whether at least ``percent`` % of the patients meet the condition.

        The share is compared exactly (9,900 of 10,000 patients meet 99 %). The worst patient
        is the one whose value lies furthest on the failing side (the highest for ``<=`` and
        ``<``, the lowest for ``>=`` and ``>``; the first patient among equals), reported
        whether the rule passed or not.
        """
        metric = METRIC_NAMES[self.metric]
        values = metrics.values[self.metric]
        if not metric.per_joint:
            values = values[:, np.newaxis]
        elif self.joint is not None:
            values = values[:, JOINT_NAMES.index(self.joint)][:, np.newaxis]
        held = int(np.count_nonzero(COMPARISONS[self.comparison](values, self.threshold).all(1)))
        count = len(metrics)
        passed = held * 100 >= Fraction(repr(self.percent)) * count
        furthest = np.argmax(values) if self.comparison in ('<=', '<') else np.argmin(values)
        patient, column = np.unravel_index(furthest, values.shape)
        joint = self.joint
        if metric.per_joint and joint is None:
            joint = JOINT_NAMES[column]
        value = float(values[patient, column])
        shown = f' ({joint})' if metric.per_joint and self.joint is None else ''
        message = (
            f'{"passed" if passed else "failed"}: {self.condition} held for '
            f'{_percent(held, count)} % of {count:,} patients ({held:,}), required '
            f'{self.percent:g} %; worst patient {patient}: {_value(value, metric.unit)}{shown}'
        )
        return RuleResult(self, bool(passed), held, count, int(patient), value, joint, message)


@dataclass(frozen=True)
class RuleResult:
    """The outcome of a rule on a trial's patients.

    Attributes
    ----------
    rule : Rule
        The rule evaluated.
    passed : bool
        Whether enough patients met the condition.
    held : int
        Patients who met it.
    patients : int
        Patients in the trial.
    worst_patient : int
        Index of the patient furthest on the failing side.
    worst_value : float
        That patient's value, in the metric's unit.
    worst_joint : str or None
        The joint of that value (None for a metric with one value per patient).
    message : str
        One line saying all of it, e.g. ``failed: peak_force_n <= 5 held for 97.2 % of 10,000
        patients (9,720), required 99 %; worst patient 4123: 8.1 N (pip)``.
    """

    rule: Rule
    passed: bool
    held: int
    patients: int
    worst_patient: int
    worst_value: float
    worst_joint: str | None
    message: str

    @property
    def status(self) -> int:
        """0: passed, 1: failed (an exit code)."""
        return 0 if self.passed else 1


def _number(name: str, text: str) -> float:
    try:
        return float(text)
    except ValueError:
        raise ValueError(f'{name} {text!r}: not a number') from None


def _percent(held: int, count: int) -> str:
    """100·held/count rounded down to 0.1, so a share short of another never shows as it."""
    return f'{(1000 * held // count) / 10:g}'


def _value(value: float, unit: str) -> str:
    """``value`` with its unit, thousands separated from 10,000 on."""
    if unit == 'steps':
        return f'{value:,.0f} steps'
    number = f'{value:,.0f}' if abs(value) >= 1e4 else f'{value:.3g}'
    return number if unit == '1' else f'{number} {unit}'
