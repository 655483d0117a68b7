"""Per-patient metrics of a trial session, accumulated step by step (docs/trials.md, "Metrics").

A trial of 10,000 patients × 6,000 steps cannot keep its records, so :class:`MetricAccumulator`
keeps only running sums, extremes and counts per patient: each :meth:`~MetricAccumulator.update`
takes one step (or a chunk of steps) of the whole batch and costs a few passes over arrays of
N × 3 numbers. :meth:`~MetricAccumulator.result` turns them into :class:`PatientMetrics`, one
value per patient (and per joint) of every metric of :data:`METRICS`, the one table that names
them, their units and their meaning for the CSV, the JSON summary and docs/trials.md.

Symbols: N patients; T steps of Δt = 1/``rate_hz``; per patient and joint (MCP, PIP, DIP) the
true joint angle q and the target q* (rad), the contact force f (N, docs/spec/model.md §6) and
the chamber pressure p (Pa).

>>> import numpy as np
>>> from exodigit_model.trials import MetricAccumulator
>>> metrics = MetricAccumulator(2)
>>> for q in (0.0, 0.5):
...     metrics.update(q=np.full((2, 3), q), target=np.zeros(3), forces=np.ones((2, 3)),
...                    pressure=np.zeros((2, 3)), limited=False, solver_warning=False,
...                    outside_model=False)
>>> metrics.result().values['rom_rad'][0].tolist()
[0.5, 0.5, 0.5]
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from types import MappingProxyType

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..checks import ParameterError, check_positive, set_field
from ..physics.params import JOINT_NAMES
from .protocols import DEFAULT_RATE, FUNCTIONAL_RANGE

DEFAULT_FORCE_LIMIT = 10.0
"""|f| above this counts as time over the force limit, N. Judgement within sourced bounds
(docs/trials.md, "Metrics"): far below the pain onset of brief clamping of the hand and fingers
(135 N, DGUV 2011), above what a soft glove rated comfortable pressed with (<= 2.94 N, Shen et
al. 2020), and equal to the ``pressure_command`` limiter's ``max_contact_force``."""


@dataclass(frozen=True)
class Metric:
    """One per-patient metric: its name (with its unit), unit, meaning and which way is worse.

    Attributes
    ----------
    name : str
        Column name; it ends with the unit (``_rad``, ``_n``, ``_s``, ``_pa``, ``_steps``) or
        says what the number is (``_fraction``).
    unit : str
        SI unit of the values (``1`` for a ratio).
    per_joint : bool
        One value per joint (columns ``name.mcp``, ``name.pip``, ``name.dip``) or one per
        patient.
    worse : str or None
        ``'high'`` or ``'low'``: which values are worse, to rank the worst patients and to pick
        a patient's worst joint; None: neither (context, not a quality).
    description : str
        What it measures.
    """

    name: str
    unit: str
    per_joint: bool
    worse: str | None
    description: str

    @property
    def columns(self) -> tuple[str, ...]:
        """The metric's columns: ``name.<joint>`` per joint, or ``name``."""
        if self.per_joint:
            return tuple(f'{self.name}.{joint}' for joint in JOINT_NAMES)
        return (self.name,)


METRICS: tuple[Metric, ...] = (
    Metric('rom_rad', 'rad', True, 'low', 'range of motion reached: max − min of q'),
    Metric('target_rom_rad', 'rad', True, None, "the target's range: max − min of q*"),
    Metric(
        'rom_fraction',
        '1',
        True,
        'low',
        'rom_rad / target_rom_rad (1 where the target does not move)',
    ),
    Metric(
        'functional_rom_fraction',
        '1',
        True,
        'low',
        'share of the functional range of motion (Bain et al. 2015) inside [min q, max q]',
    ),
    Metric('tracking_rmse_rad', 'rad', True, 'high', 'root mean square of q − q* over the steps'),
    Metric(
        'overall_tracking_rmse_rad',
        'rad',
        False,
        'high',
        'root mean square of q − q* over the steps and the three joints',
    ),
    Metric('peak_force_n', 'N', True, 'high', 'largest |f| (push or pull) at the contact'),
    Metric('mean_force_n', 'N', True, 'high', 'mean of |f| over the steps'),
    Metric(
        'time_over_force_s',
        's',
        False,
        'high',
        'time with |f| above the force limit at one contact or more: steps · Δt',
    ),
    Metric('peak_pressure_pa', 'Pa', True, 'high', 'highest chamber pressure'),
    Metric(
        'limiter_steps',
        'steps',
        False,
        'high',
        'steps in which the safety limiter changed the command',
    ),
    Metric(
        'solver_warning_steps',
        'steps',
        False,
        'high',
        'steps whose solve did not converge (the glove kept its last good state)',
    ),
    Metric(
        'outside_model_steps',
        'steps',
        False,
        'high',
        'steps whose state left the validated model: a fibre stretch outside the validated '
        'range or a joint outside its range of motion',
    ),
)
"""Every per-patient metric, in the order of the CSV columns."""

METRIC_NAMES: Mapping[str, Metric] = MappingProxyType({metric.name: metric for metric in METRICS})
"""The metrics by name."""


@dataclass(frozen=True, kw_only=True)
class MetricSettings:
    """How the steps are turned into metrics.

    Attributes
    ----------
    rate_hz : float
        Steps per second of the session, Hz (> 0): a step lasts Δt = 1/rate_hz.
    force_limit : float
        |f| above this (strictly) counts towards ``time_over_force_s``, N (> 0).
        Default :data:`DEFAULT_FORCE_LIMIT`.
    functional_rom : tuple of two tuples of float
        The functional range of motion, (lower ends, upper ends) per joint, rad, lower < upper.
        Default :data:`~.protocols.FUNCTIONAL_RANGE` (Bain et al. 2015).
    """

    rate_hz: float = DEFAULT_RATE
    force_limit: float = DEFAULT_FORCE_LIMIT
    functional_rom: tuple[tuple[float, float, float], tuple[float, float, float]] = (
        FUNCTIONAL_RANGE
    )

    def __post_init__(self) -> None:
        """Refuse a rate or limit that is not > 0, or a functional range that is not one."""
        set_field(self, 'rate_hz', check_positive('rate_hz', self.rate_hz, 'Hz'))
        set_field(self, 'force_limit', check_positive('force_limit', self.force_limit, 'N'))
        try:
            ends = np.array(self.functional_rom, dtype=float)
        except (TypeError, ValueError):
            ends = None
        if ends is None or ends.shape != (2, 3) or not np.all(np.isfinite(ends)):
            raise ParameterError(
                f'functional_rom = {self.functional_rom!r}: must be (lower ends, upper ends), '
                'three finite angles each, rad'
            )
        if not np.all(ends[0] < ends[1]):
            joint = JOINT_NAMES[int(np.argmin(ends[0] < ends[1]))]
            raise ParameterError(
                f'functional_rom at the {joint}: lower end must be below the upper end'
            )
        set_field(self, 'functional_rom', (tuple(ends[0].tolist()), tuple(ends[1].tolist())))


@dataclass(frozen=True)
class PatientMetrics:
    """Every metric of :data:`METRICS` for each patient of a session.

    Attributes
    ----------
    values : mapping of str to ndarray
        Per metric name, a read-only array: shape (N, 3) (patient, joint MCP, PIP, DIP) for a
        per-joint metric, (N,) otherwise; in the metric's unit; always finite.
    steps : int
        Steps the session had.
    settings : MetricSettings
        The rate, force limit and functional range the values were made with.
    """

    values: Mapping[str, NDArray[np.float64]]
    steps: int
    settings: MetricSettings = field(default_factory=MetricSettings)

    def __len__(self) -> int:
        """N, the number of patients."""
        return len(self.values[METRICS[0].name])

    @property
    def duration(self) -> float:
        """Length of the session, s."""
        return self.steps / self.settings.rate_hz

    def column(self, name: str) -> NDArray[np.float64]:
        """One value per patient, shape (N,): ``metric.<joint>``, or ``metric``.

        A per-joint metric named without a joint gives each patient's worst joint (the highest
        or lowest value, as the metric's ``worse`` says).

        Raises
        ------
        KeyError
            For an unknown metric or joint, or a per-joint metric without a joint whose
            ``worse`` is None.
        """
        metric_name, _, joint = name.partition('.')
        metric = METRIC_NAMES.get(metric_name)
        if metric is None or (joint and (not metric.per_joint or joint not in JOINT_NAMES)):
            raise KeyError(f'{name!r}: no such column (known: {", ".join(column_names())})')
        values = self.values[metric_name]
        if joint:
            return values[:, JOINT_NAMES.index(joint)]
        if not metric.per_joint:
            return values
        if metric.worse is None:
            raise KeyError(f'{name!r}: has no worst joint; name one ({metric_name}.mcp, …)')
        return values.max(axis=1) if metric.worse == 'high' else values.min(axis=1)

    def columns(self) -> dict[str, NDArray[np.float64]]:
        """Every column of :func:`column_names`, in order: the rows of a per-patient CSV."""
        return {name: self.column(name) for name in column_names()}

    @classmethod
    def concatenate(cls, parts: Sequence[PatientMetrics]) -> PatientMetrics:
        """The patients of ``parts`` one after the other (e.g. the shards of one trial).

        Raises
        ------
        ValueError
            If there are no parts, or their steps or settings differ.
        """
        if not parts:
            raise ValueError('concatenate: no parts')
        first = parts[0]
        for part in parts[1:]:
            if (part.steps, part.settings) != (first.steps, first.settings):
                raise ValueError(
                    'concatenate: every part must have the same steps and settings, got '
                    f'{part.steps} steps, {part.settings} after {first.steps} steps, '
                    f'{first.settings}'
                )
        values = {
            metric.name: np.concatenate([part.values[metric.name] for part in parts])
            for metric in METRICS
        }
        return cls(_read_only(values), first.steps, first.settings)


def column_names() -> tuple[str, ...]:
    """Every column of :data:`METRICS` in order (``name.<joint>`` for a per-joint metric)."""
    return tuple(column for metric in METRICS for column in metric.columns)


def _read_only(values: dict[str, NDArray[np.float64]]) -> Mapping[str, NDArray[np.float64]]:
    for array in values.values():
        array.flags.writeable = False
    return MappingProxyType(values)


class MetricAccumulator:
    """Running per-patient sums, extremes and counts over the steps of a session.

    Parameters
    ----------
    count : int
        N, the number of patients (>= 1).
    settings : MetricSettings, optional
        Rate, force limit and functional range; the defaults when omitted.

    Notes
    -----
    Memory is a dozen arrays of N × 3 numbers whatever the length of the session. Feeding the
    steps in one :meth:`update` or in many gives the same result (sums in another order may
    differ in the last bits).
    """

    def __init__(self, count: int, settings: MetricSettings | None = None) -> None:
        if isinstance(count, bool) or not isinstance(count, int) or count < 1:
            raise ValueError(f'count = {count!r}: must be a whole number >= 1')
        self.count = count
        self.settings = MetricSettings() if settings is None else settings
        self.steps = 0
        """Steps accumulated so far."""
        shape = (count, 3)
        self._q_min, self._q_max = np.full(shape, np.inf), np.full(shape, -np.inf)
        # the target's extremes: one for every patient (shared targets) and each patient's own
        self._shared_min, self._shared_max = np.full(3, np.inf), np.full(3, -np.inf)
        self._own_min, self._own_max = np.full(shape, np.inf), np.full(shape, -np.inf)
        self._squared_error = np.zeros(shape)
        self._peak_force, self._force_sum = np.zeros(shape), np.zeros(shape)
        self._peak_pressure = np.full(shape, -np.inf)
        self._over_force = np.zeros(count, dtype=np.int64)
        self._limited = np.zeros(count, dtype=np.int64)
        self._warnings = np.zeros(count, dtype=np.int64)
        self._outside = np.zeros(count, dtype=np.int64)

    def update(
        self,
        *,
        q: ArrayLike,
        target: ArrayLike,
        forces: ArrayLike,
        pressure: ArrayLike,
        limited: ArrayLike,
        solver_warning: ArrayLike,
        outside_model: ArrayLike,
    ) -> None:
        """Add one step of the batch, or a chunk of T steps (a leading axis of T).

        Parameters
        ----------
        q : array_like, shape (N, 3), or (T, N, 3)
            True joint angles after the step, rad.
        target : array_like, shape (3,) or (N, 3), or (T, 3) or (T, N, 3)
            Target joint angles at the same time, rad: one for every patient or one each.
        forces : array_like, shape like ``q``
            Contact forces, N.
        pressure : array_like, shape like ``q``
            Chamber pressures, Pa.
        limited : array_like of bool, shape (N,), or (T, N), or one bool for all
            Whether the safety limiter changed the patient's command in the step.
        solver_warning : array_like of bool, shape like ``limited``
            Whether the patient's solve did not converge in the step.
        outside_model : array_like of bool, shape like ``limited``
            Whether the patient's state after the step lies outside the validated model: not
            ``in_valid_range and in_range_of_motion`` (docs/spec/model.md §7).

        Raises
        ------
        ValueError
            If an array has the wrong shape or type, or a non-finite value; nothing is added
            then.
        """
        q = self._rows('q', q)
        steps = q.shape[0]
        target = self._targets(target, steps)
        forces = self._rows('forces', forces, steps)
        pressure = self._rows('pressure', pressure, steps)
        limited = self._flags('limited', limited, steps)
        solver_warning = self._flags('solver_warning', solver_warning, steps)
        outside_model = self._flags('outside_model', outside_model, steps)

        # Elementwise work on (N, 3) arrays, never broadcasting a (3,) row over them: numpy
        # runs such a broadcast (and any reduction over the last axis of 3) in inner loops of
        # three, about ten times slower. So: per-joint columns for the error and the largest
        # contact, and a shared target's extremes kept apart from the patients' own.
        np.minimum(self._q_min, _reduce(np.minimum, q), out=self._q_min)
        np.maximum(self._q_max, _reduce(np.maximum, q), out=self._q_max)
        shared = target.ndim == 2
        low, high = (
            (self._shared_min, self._shared_max) if shared else (self._own_min, self._own_max)
        )
        np.minimum(low, _reduce(np.minimum, target), out=low)
        np.maximum(high, _reduce(np.maximum, target), out=high)
        for joint in range(3):
            error = q[..., joint] - (
                target[:, joint, np.newaxis] if shared else target[..., joint]
            )
            error *= error
            column = self._squared_error[:, joint]
            column += _reduce(np.add, error)
        magnitude = np.abs(forces)
        np.maximum(self._peak_force, _reduce(np.maximum, magnitude), out=self._peak_force)
        self._force_sum += _reduce(np.add, magnitude)
        largest = np.maximum(np.maximum(magnitude[..., 0], magnitude[..., 1]), magnitude[..., 2])
        self._over_force += np.count_nonzero(largest > self.settings.force_limit, axis=0)
        np.maximum(self._peak_pressure, _reduce(np.maximum, pressure), out=self._peak_pressure)
        self._limited += np.count_nonzero(limited, axis=0)
        self._warnings += np.count_nonzero(solver_warning, axis=0)
        self._outside += np.count_nonzero(outside_model, axis=0)
        self.steps += steps

    def result(self) -> PatientMetrics:
        """The metrics of the steps so far (the accumulator can go on afterwards).

        Raises
        ------
        ValueError
            If no step has been added.
        """
        if self.steps == 0:
            raise ValueError('no steps accumulated: call update() first')
        steps, rate = self.steps, self.settings.rate_hz
        rom = self._q_max - self._q_min
        target_rom = np.maximum(self._own_max, self._shared_max) - np.minimum(
            self._own_min, self._shared_min
        )
        rom_fraction = np.divide(rom, target_rom, out=np.ones_like(rom), where=target_rom > 0.0)
        low, high = (np.array(ends) for ends in self.settings.functional_rom)
        overlap = np.minimum(self._q_max, high) - np.maximum(self._q_min, low)
        mean_square = self._squared_error / steps
        values = {
            'rom_rad': rom,
            'target_rom_rad': target_rom,
            'rom_fraction': rom_fraction,
            'functional_rom_fraction': np.clip(overlap, 0.0, None) / (high - low),
            'tracking_rmse_rad': np.sqrt(mean_square),
            'overall_tracking_rmse_rad': np.sqrt(mean_square.mean(axis=1)),
            'peak_force_n': self._peak_force.copy(),
            'mean_force_n': self._force_sum / steps,
            'time_over_force_s': self._over_force / rate,
            'peak_pressure_pa': self._peak_pressure.copy(),
            'limiter_steps': self._limited.astype(float),
            'solver_warning_steps': self._warnings.astype(float),
            'outside_model_steps': self._outside.astype(float),
        }
        return PatientMetrics(_read_only(values), steps, self.settings)

    # -- input checks ----------------------------------------------------------------------

    def _rows(self, name: str, value: ArrayLike, steps: int | None = None) -> NDArray:
        """``value`` as finite floats of shape (T, N, 3) (a view where it can be)."""
        array = _floats(name, value)
        if array.ndim == 2:
            array = array[np.newaxis]
        expected = (steps if steps is not None else array.shape[0], self.count, 3)
        if array.shape != expected or expected[0] < 1:
            raise ValueError(
                f'{name} must have shape {expected[1:]} (one step) or {expected} '
                f'(T steps: patient, joint MCP, PIP, DIP), got {np.shape(value)}'
            )
        _check_finite(name, array)
        return array

    def _targets(self, value: ArrayLike, steps: int) -> NDArray:
        """``value`` as finite floats of shape (T, 3) (one for all) or (T, N, 3) (one each)."""
        array = _floats('target', value)
        shapes = {(steps, 3): (steps, 3), (steps, self.count, 3): (steps, self.count, 3)}
        if steps == 1:
            shapes |= {(3,): (1, 3), (self.count, 3): (1, self.count, 3)}
        if array.shape not in shapes:
            raise ValueError(
                f'target must have shape {" or ".join(map(str, shapes))} for {steps} step(s) '
                f'of {self.count} patients, got {array.shape}'
            )
        array = array.reshape(shapes[array.shape])
        _check_finite('target', array)
        return array

    def _flags(self, name: str, value: ArrayLike, steps: int) -> NDArray[np.bool_]:
        """``value`` as bools of shape (T, N)."""
        array = np.asarray(value)
        if array.dtype != np.bool_:
            raise ValueError(f'{name} must be bool (True/False), got dtype {array.dtype}')
        shapes = {(), (steps, self.count)} | ({(self.count,)} if steps == 1 else set())
        if array.shape not in shapes:
            raise ValueError(
                f'{name} must have shape ({self.count},) for one step or ({steps}, '
                f'{self.count}) for {steps}, or be one bool for every patient, got {array.shape}'
            )
        return np.broadcast_to(array, (steps, self.count))


def _reduce(ufunc: np.ufunc, chunk: NDArray) -> NDArray:
    """``ufunc`` reduced over the steps of ``chunk`` (its first axis); one step as it is."""
    return chunk[0] if len(chunk) == 1 else ufunc.reduce(chunk, axis=0)


def _floats(name: str, value: ArrayLike) -> NDArray[np.float64]:
    try:
        return np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        raise ValueError(f'{name} = {value!r}: must be an array of numbers') from None


def _check_finite(name: str, array: NDArray[np.float64]) -> None:
    """Refuse a non-finite value of ``array`` (T, 3) or (T, N, 3), saying where it is."""
    if np.isfinite(array).all():
        return
    where = tuple(np.argwhere(~np.isfinite(array))[0])
    step, *patient, joint = where
    whose = f', patient {patient[0]}' if patient else ''
    raise ValueError(
        f'{name} is not finite: {array[where]} at step {step} of the update{whose}, '
        f'{JOINT_NAMES[joint]}'
    )
