"""Running a trial: the population in shards, each stepped as one batch, the metrics merged.

docs/trials.md, "Runner". A trial's N patients are split into shards of ``shard_size``
(:func:`shard_bounds`). A shard is one batch on the compiled stepper
(:class:`~exodigit_model.stepping.simulation.GloveSimulation` with one finger per patient), the
controller answering the whole batch at every step and :class:`~.metrics.MetricAccumulator` taking
every step (:func:`run_shard`). An :class:`Engine` runs the shards (:class:`LocalEngine` one after
the other in this process; ``exodigit_model.trials.ray_engine.RayEngine`` on a Ray cluster) and
:func:`run_trial` joins them, summarizes them and judges the rules.

A shard's result depends on the spec and the shard's index only: its patients are rows a:b of
``population.sample(b, seed)`` (patient i does not depend on the count), its sensor noise and
its controller's generator come from ``np.random.SeedSequence([seed, index])``
(:func:`shard_seeds`). So any engine gives the same per-patient results, bit for bit. Without
sensor noise (the plant's default) the shard size does not change them either; with noise it
does (a batch draws its noise for all its gloves at once).

>>> from exodigit_model.trials import TrialSpec, run_trial
>>> result = run_trial(TrialSpec(patients=4, protocol_parameters={'duration': 0.5}),
...                    rules=['peak_force_n <= 10 for 100%'])
>>> result.status, len(result.metrics)
(0, 4)
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass
from types import MappingProxyType
from typing import Any, NamedTuple, Protocol, runtime_checkable

import numpy as np
from numpy.typing import NDArray

from ..control import ValveLoop
from ..physics.model import GloveModel
from ..physics.populations import Patients
from ..stepping.simulation import GloveSimulation
from .aggregates import summarize
from .controllers import build_controller, limiter_acted
from .metrics import MetricAccumulator, PatientMetrics
from .rules import Rule, RuleResult
from .spec import TrialSpec

OnDone = Callable[[int, PatientMetrics], None]
"""on_done(index, metrics): called by an engine as each shard finishes (in any order)."""


def shard_bounds(spec: TrialSpec) -> list[tuple[int, int]]:
    """The patients of each shard, [(a, b), ...]: rows a ≤ i < b, in order.

    Each shard has ``shard_size`` patients, the last what is left; together they cover
    0 … ``spec.patients`` − 1.
    """
    size, count = spec.shard_size, spec.patients
    return [(start, min(start + size, count)) for start in range(0, count, size)]


def shard_seeds(spec: TrialSpec, index: int) -> tuple[int, np.random.Generator]:
    """The sensor-noise seed and the controller's generator of shard ``index``.

    Both come from ``np.random.SeedSequence([spec.seed, index])``, spawned in two: the first
    child gives the noise seed (its first 64-bit word, the simulation's ``seed``), the second
    the controller's ``Generator`` (passed to ``reset(count, rng)``).
    """
    noise, controller = np.random.SeedSequence([spec.seed, index]).spawn(2)
    return int(noise.generate_state(1, np.uint64)[0]), np.random.default_rng(controller)


def shard_patients(spec: TrialSpec, index: int) -> Patients:
    """The patients of shard ``index``: rows a:b of ``population.sample(b, seed)``."""
    start, stop = shard_bounds(spec)[_index(spec, index)]
    drawn = spec.load_population().sample(stop, spec.seed, base=spec.glove_params().finger)
    rows = MappingProxyType({key: values[start:stop] for key, values in drawn.arrays.items()})
    return Patients(drawn.population, drawn.seed, rows, drawn.base)


class PatientRecord(NamedTuple):
    """One patient's session, step by step: arrays (steps, 3), SI.

    Attributes
    ----------
    patient : int
        The patient's index in the trial.
    t : ndarray, shape (steps,)
        t_k, s.
    q, target : ndarray
        True joint angles and the protocol's targets, rad.
    pressure, command : ndarray
        Chamber pressures and the commands that drove each step, Pa (behind valves the
        controller's pressure targets the valve loop tracked).
    forces : ndarray
        Contact forces, N.
    limited : ndarray of bool, shape (steps,)
        Whether the limiter changed the command.
    openings : ndarray or None
        Behind valves the six openings of each step, (steps, 6): inlets MCP, PIP, DIP, then
        outlets; None with regulators.
    """

    patient: int
    t: NDArray[np.float64]
    q: NDArray[np.float64]
    target: NDArray[np.float64]
    pressure: NDArray[np.float64]
    command: NDArray[np.float64]
    forces: NDArray[np.float64]
    limited: NDArray[np.bool_]
    openings: NDArray[np.float64] | None = None


def run_shard(spec: TrialSpec, index: int) -> PatientMetrics:
    """The metrics of shard ``index``'s patients, in their order; the same for the same inputs.

    Raises
    ------
    IndexError
        For an index outside ``range(spec.shards)``.
    ValueError
        If the controller fails to be made or gives commands of the wrong shape.
    """
    return _session(spec, index)[0]


def record_patient(spec: TrialSpec, patient: int) -> PatientRecord:
    """Patient ``patient``'s session step by step, exactly as in the trial.

    The patient's whole shard is run again (the controller and the noise see the same batch),
    recording that one row.
    """
    if not 0 <= patient < spec.patients:
        raise IndexError(f'patient {patient}: the trial has patients 0 … {spec.patients - 1}')
    index = patient // spec.shard_size
    record = _session(spec, index, record=patient - index * spec.shard_size)[1]
    return record._replace(patient=patient)


def _index(spec: TrialSpec, index: int) -> int:
    if isinstance(index, bool) or not isinstance(index, int | np.integer):
        raise IndexError(f'shard {index!r}: must be a whole number')
    if not 0 <= index < spec.shards:
        raise IndexError(f'shard {index}: the trial has shards 0 … {spec.shards - 1}')
    return int(index)


def _session(
    spec: TrialSpec, index: int, *, record: int | None = None
) -> tuple[PatientMetrics, PatientRecord | None]:
    """Step shard ``index`` through the session; record row ``record`` when given."""
    patients = shard_patients(spec, index)
    count, protocol = len(patients), spec.session()
    model = GloveModel(spec.glove_params())
    noise_seed, rng = shard_seeds(spec, index)
    settings = spec.simulation_settings(noise_seed)
    simulation = GloveSimulation(
        model, settings, fingers=patients.fingers, actuation=spec.actuation
    )
    controller = build_controller(
        spec.controller, protocol=protocol, model=model, settings=settings
    )
    controller.reset(count, rng)
    valves = ValveLoop(spec.valve_loop(), count=count) if simulation.valves else None
    metrics = MetricAccumulator(count, spec.metric_settings())
    times = protocol.times()
    targets = protocol.targets(times)
    rows = [] if record is not None else None
    state = simulation.state
    for target in targets:
        command = controller.command(state.t, simulation.period, state)
        if valves is None:
            state = simulation.step(command)
        else:  # the commands are the loop's targets; it answers the measured pressures
            state = simulation.step(
                valves.openings(command, state.pressure_measured, simulation.period)
            )
        limited = limiter_acted(controller, count)
        metrics.update(
            q=state.q,
            target=target,
            forces=state.forces,
            pressure=state.pressure,
            limited=limited,
            solver_warning=~state.converged,
            outside_model=~(state.in_valid_range & state.in_range_of_motion),
        )
        if rows is not None:
            flags = np.broadcast_to(limited, (count,))
            pressures = state.command if valves is None else np.asarray(command)
            recorded = (state.q, state.pressure, pressures, state.forces, flags, state.command)
            rows.append(tuple(value[record] for value in recorded))
    if rows is None:
        return metrics.result(), None
    q, pressure, command, forces, limited, applied = (
        np.array(column) for column in zip(*rows, strict=True)
    )
    openings = None if valves is None else applied
    return metrics.result(), PatientRecord(
        record, times, q, targets, pressure, command, forces, limited, openings
    )


@runtime_checkable
class Engine(Protocol):
    """What runs a trial's shards: here, one after the other, or elsewhere (e.g. on Ray)."""

    def map(
        self, spec: TrialSpec, indices: Sequence[int], on_done: OnDone
    ) -> list[PatientMetrics]:
        """:func:`run_shard` of every index; the results in the order of ``indices``.

        ``on_done(index, metrics)`` is called as each shard finishes (for progress).
        """


class LocalEngine:
    """Runs the shards one after the other in this process."""

    def map(
        self, spec: TrialSpec, indices: Sequence[int], on_done: OnDone
    ) -> list[PatientMetrics]:
        """:meth:`Engine.map`, in this process, in order."""
        results = []
        for index in indices:
            results.append(run_shard(spec, index))
            on_done(index, results[-1])
        return results


@dataclass(frozen=True)
class TrialResult:
    """A trial's outcome: per-patient metrics, their summary, and the rules' verdicts.

    Attributes
    ----------
    spec : TrialSpec
        The trial.
    metrics : PatientMetrics
        Every metric of every patient, patients in their order.
    patients : Patients
        The patients' parameters (``arrays``: per field, (N, 3), SI).
    summary : dict
        :func:`~.aggregates.summarize` of the metrics (plain values, for JSON).
    rules : tuple of RuleResult
        Each rule's outcome, in the order given.
    status : int
        0: every rule passed (or none given); 1: at least one failed.
    message : str
        One line: how many patients, and the rules held or failed.
    """

    spec: TrialSpec
    metrics: PatientMetrics
    patients: Patients
    summary: dict[str, Any]
    rules: tuple[RuleResult, ...]
    status: int
    message: str

    @property
    def passed(self) -> bool:
        """Whether every rule passed."""
        return self.status == 0

    def worst_patient(self) -> int:
        """The patient to look at first.

        The worst patient of the first rule that failed, else the one with the highest peak
        contact force.
        """
        failed = [outcome for outcome in self.rules if not outcome.passed]
        if failed:
            return failed[0].worst_patient
        return int(np.argmax(self.metrics.column('peak_force_n')))


def run_trial(
    spec: TrialSpec,
    *,
    rules: Iterable[Rule | str] = (),
    engine: Engine | None = None,
    progress: bool | None = None,
) -> TrialResult:
    """Run the trial: every shard on ``engine``, the metrics joined, summarized and judged.

    Parameters
    ----------
    spec : TrialSpec
        The trial.
    rules : iterable of Rule or str
        Pass/fail rules (``'peak_force_n <= 5 for 99%'``, docs/trials.md, "Rules").
    engine : Engine, optional
        Runs the shards; default :class:`LocalEngine`.
    progress : bool, optional
        A progress bar over the patients on stderr (tqdm, of the ``tools`` extra; shown on a
        terminal only): True always, False never, None (default) when the trial has more than
        one shard. Without tqdm there is no bar and no error.

    Returns
    -------
    TrialResult

    Raises
    ------
    ValueError
        For a rule that does not parse, or a controller that cannot be made.
    """
    judged = tuple(rule if isinstance(rule, Rule) else Rule.parse(rule) for rule in rules)
    engine = LocalEngine() if engine is None else engine
    indices = list(range(spec.shards))
    bar = _bar(spec, progress)

    def on_done(index: int, part: PatientMetrics) -> None:
        if bar is not None:
            bar.update(len(part))

    try:
        parts = engine.map(spec, indices, on_done)
    finally:
        if bar is not None:
            bar.close()
    metrics = PatientMetrics.concatenate(parts)
    outcomes = tuple(rule.evaluate(metrics) for rule in judged)
    failed = [outcome for outcome in outcomes if not outcome.passed]
    held = f'{len(outcomes) - len(failed)} of {len(outcomes)} rules passed'
    message = f'{"failed" if failed else "passed"}: {spec.patients:,} patients, {held}'
    return TrialResult(
        spec,
        metrics,
        spec.load_population().sample(spec.patients, spec.seed, base=spec.glove_params().finger),
        summarize(metrics),
        outcomes,
        1 if failed else 0,
        message,
    )


def _bar(spec: TrialSpec, progress: bool | None) -> Any:
    """A tqdm bar over the patients, or None (not wanted, or tqdm missing)."""
    if progress is False or (progress is None and spec.shards < 2):
        return None
    from ..extras import ToolError
    from ..extras import progress as tqdm_bar

    try:
        return tqdm_bar(total=spec.patients, desc='trial', unit='patient')
    except ToolError:
        return None
