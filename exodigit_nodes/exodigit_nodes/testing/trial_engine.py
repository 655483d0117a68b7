"""Virtual patient trials of a user's ROS node controller on the testing kit's gloves.

docs/trials.md, "A ROS node as the controller". :class:`KitEngine` is an engine of
:func:`exodigit_model.trials.run_trial` (``map(spec, indices, on_done)``) for a trial whose
controller is a ROS node (``ControllerSpec('ros', command_line, ros_parameters)``, made by
:func:`ros_controller`). Each patient runs on a glove (:class:`~.target_run.TargetGloveSim`: a
plant in lockstep simulated time, in a private domain and namespace) whose plant simulates that
patient (the trial's glove with the patient's finger, the trial's chamber and sensor settings,
at the protocol's rate), with the controller's command started there with ``use_sim_time``; the
kit sends the protocol's targets as one ``joint_trajectory`` (one point a step,
:meth:`~exodigit_model.trials.SessionProtocol.trajectory`) and lets the plant step in lockstep
with the node, and the recorded states go into the same
:class:`~exodigit_model.trials.MetricAccumulator` as an in-process trial's. So the metrics,
summary, rules and report are the same; what a ROS node cannot report is stated in
:func:`patient_metrics`.

Up to ``parallel`` gloves run at once, each in its own ROS domain and driven by a worker process
of its own (:mod:`.trial_worker`). A glove and its node serve patient after patient: each
patient is a new session of the plant (``reset_simulation``: simulated time goes back to zero),
on which the node starts over, so a patient costs its steps, not a start of two processes;
``fresh_nodes=True`` starts both afresh for every patient instead, for a node that does not
start over.

>>> import sys
>>> from exodigit_model.trials import TrialSpec, run_trial
>>> spec = TrialSpec(patients=4, protocol='grasp', protocol_parameters={'duration': 5.0},
...                  controller=ros_controller(
...                      [sys.executable, '-m', 'exodigit_nodes.nodes.pressure_command'],
...                      mode='position', lockstep=True))
>>> with KitEngine(parallel=2) as engine:                      # doctest: +SKIP
...     result = run_trial(spec, engine=engine)
"""

from __future__ import annotations

import shlex
import tempfile
import threading
from collections.abc import Callable, Sequence
from concurrent.futures import FIRST_COMPLETED, Future, ThreadPoolExecutor, wait
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np
from exodigit_model.physics.params import dump_params
from exodigit_model.trials import ControllerSpec, MetricAccumulator, PatientMetrics, TrialSpec
from exodigit_model.trials.trial import OnDone, PatientRecord, shard_bounds, shard_patients

from .client import DEFAULT_TIMEOUT
from .target_run import TargetRecord
from .trial_worker import PatientJob, PatientRun, Worker

DEFAULT_PARALLEL = 2
"""Gloves at once by default: each takes its plant's, its controller's and its driver's share of
a core (benchmarks/bench_trial_ros.py)."""
SEED_LIMIT = 2**31
"""The plant's ``seed`` is below this."""


def ros_controller(command: str | Sequence[str], **parameters: Any) -> ControllerSpec:
    """The :class:`ControllerSpec` of a ROS node controller.

    Parameters
    ----------
    command : str or sequence of str
        The command that starts the node: a command line (split as a shell does) or its argv,
        e.g. ``['ros2', 'run', 'my_pkg', 'my_node']`` or ``[sys.executable, 'my_node.py']``.
    **parameters
        The node's ROS parameters, given as ``-p name:=value``.
    """
    line = command if isinstance(command, str) else shlex.join(command)
    return ControllerSpec('ros', line, parameters)


def plant_parameters(spec: TrialSpec, patient: int) -> dict[str, Any]:
    """The plant parameters of ``patient``'s glove: the trial's settings, the patient's seed.

    The sensor-noise seed is the patient's own (from ``SeedSequence([seed, patient])``): a
    plant draws its noise alone, so it cannot repeat an in-process batch's draws.
    """
    settings = spec.simulation_settings(0)
    noise = np.random.SeedSequence([spec.seed, patient]).generate_state(1, np.uint64)[0]
    return {
        'rate_hz': float(settings.rate_hz),
        'pressure_time_constant': float(settings.pressure_time_constant),
        'max_supply_pressure': float(settings.max_supply_pressure),
        'angle_noise_std': float(settings.angle_noise_std),
        'pressure_noise_std': float(settings.pressure_noise_std),
        'seed': int(noise % SEED_LIMIT),
    }


class PatientError(RuntimeError):
    """A patient's glove run failed; the trial stops (the message is the run's).

    Attributes
    ----------
    run : PatientRun
        The failed run (``status`` 1, ``message``).
    """

    def __init__(self, run: PatientRun) -> None:
        self.run = run
        super().__init__(run.message)


def patient_metrics(spec: TrialSpec, record: TargetRecord) -> PatientMetrics:
    """One patient's metrics from a kit run, through the trial's :class:`MetricAccumulator`.

    Each step counts with the published angles (true ones without the plant's angle noise),
    the target the kit delivered for it, the contact forces and the chamber pressures. A ROS
    node does not say when a safety limiter of its own changed its command, and the plant's
    state topics do not say when a solve did not converge or the state left the validated model
    (its ``/diagnostics`` do, once a period, not per step), so ``limiter_steps``,
    ``solver_warning_steps`` and ``outside_model_steps`` are 0.
    """
    metrics = MetricAccumulator(1, spec.metric_settings())
    steps = len(record.t)
    no = np.zeros((steps, 1), dtype=bool)
    metrics.update(
        q=record.q[:, np.newaxis],
        target=record.target[:, np.newaxis],
        forces=record.forces[:, np.newaxis],
        pressure=record.pressure[:, np.newaxis],
        limited=no,
        solver_warning=no,
        outside_model=no,
    )
    return metrics.result()


def patient_record(spec: TrialSpec, patient: int, record: TargetRecord) -> PatientRecord:
    """A kit run as the in-process :class:`PatientRecord` (times from the session's start)."""
    return PatientRecord(
        patient,
        spec.session().times(),
        record.q,
        record.target,
        record.pressure,
        record.command,
        record.forces,
        np.zeros(len(record.t), dtype=bool),
    )


def kit_shard(
    spec: TrialSpec,
    index: int,
    *,
    timeout: float = DEFAULT_TIMEOUT,
    follows_targets: bool = True,
    fresh_nodes: bool = False,
) -> PatientMetrics:
    """Shard ``index`` of a ROS node controller's trial on this machine, one glove at a time.

    What a Ray task runs to spread a trial's gloves over a cluster's nodes::

        RayEngine(address, shard=functools.partial(kit_shard, timeout=60.0))

    Every node needs exodigit_nodes and the controller's command; the gloves of a node claim
    its free ROS domains as the kit does anywhere.

    Raises
    ------
    PatientError
        When a patient's run fails.
    """
    engine = KitEngine(
        1,
        timeout=timeout,
        follows_targets=follows_targets,
        fresh_nodes=fresh_nodes,
        keep_records=False,
    )
    return engine.map(spec, [index], lambda *_: None)[0]


class KitEngine:
    """Runs a trial of a ROS node controller on the testing kit (module docstring).

    Parameters
    ----------
    parallel : int
        Gloves at once (>= 1), each with a worker process of its own.
    timeout : float
        Longest wall-clock wait for any answer of a glove or the controller, s.
    follows_targets : bool
        Whether the controller subscribes ``joint_trajectory`` (the protocol's targets): each
        glove then waits for that subscription before the session. False for one that does not
        (open loop); the targets are sent and scored all the same.
    fresh_nodes : bool
        Start a glove and the controller for every patient, and stop them after it, for a node
        that does not start over when simulated time goes back. False (default): each glove
        and its node serve patient after patient, a new session each (module text): about 2 s
        a patient of 10 s instead of 8 (benchmarks/bench_trial_ros.py).
    log_dir : str or Path, optional
        Keep the patients' parameter files in ``log_dir/patient_<i>/``, and in the first
        patient's folder of each glove that glove's node output (the plant's, the controller's
        ``controller.out``/``.err``); a temporary folder, removed after each :meth:`map`, when
        omitted.
    keep_records : bool
        Keep every patient's session in :attr:`records` (about 0.15 kB a step).
    on_patient : callable, optional
        ``on_patient(run)`` with each :class:`PatientRun` as it finishes (progress).

    Attributes
    ----------
    records : dict of int to PatientRecord
        The sessions of the last :meth:`map`'s patients (with ``keep_records``), e.g. for
        ``write_report(result, out, record=engine.records[result.worst_patient()])``.
    runs : list of PatientRun
        Every patient's run of the last :meth:`map`, in the order they finished.
    """

    def __init__(
        self,
        parallel: int = DEFAULT_PARALLEL,
        *,
        timeout: float = DEFAULT_TIMEOUT,
        follows_targets: bool = True,
        fresh_nodes: bool = False,
        log_dir: str | Path | None = None,
        keep_records: bool = True,
        on_patient: Callable[[PatientRun], None] | None = None,
    ) -> None:
        if isinstance(parallel, bool) or not isinstance(parallel, int) or parallel < 1:
            raise ValueError(f'parallel = {parallel!r}: must be a whole number >= 1')
        if not timeout > 0.0:
            raise ValueError(f'timeout = {timeout!r}: must be > 0 s')
        self.parallel = parallel
        self.timeout = float(timeout)
        self.follows_targets = follows_targets
        self.fresh_nodes = fresh_nodes
        self.log_dir = None if log_dir is None else Path(log_dir)
        self.keep_records = keep_records
        self.on_patient = on_patient
        self.records: dict[int, PatientRecord] = {}
        self.runs: list[PatientRun] = []

    def __enter__(self) -> KitEngine:
        return self

    def __exit__(self, *exc_info) -> None:
        """Nothing stays open between maps; here for symmetry with the Ray engine."""

    def map(
        self, spec: TrialSpec, indices: Sequence[int], on_done: OnDone
    ) -> list[PatientMetrics]:
        """Every patient of the shards ``indices`` on the gloves; metrics per shard.

        Raises
        ------
        ValueError
            If the spec's controller is not a ROS node.
        PatientError
            When a patient's run fails (the gloves in flight are stopped, none starts).
        """
        if spec.controller.kind != 'ros':
            raise ValueError(
                f'controller {spec.controller}: KitEngine runs a ROS node controller (kind '
                "'ros'); run the others with the local or Ray engine"
            )
        self.records, self.runs = {}, []
        bounds = shard_bounds(spec)
        workers: list[Worker] = []
        local = threading.local()
        lock = threading.Lock()

        def run(job: PatientJob) -> PatientRun:  # in a pool thread, on that thread's worker
            if not hasattr(local, 'worker'):
                local.worker = Worker()
                with lock:
                    workers.append(local.worker)
            return local.worker.run(job)

        with tempfile.TemporaryDirectory(prefix='exodigit_kit_trial_') as scratch:
            root = Path(scratch) if self.log_dir is None else self.log_dir
            jobs = {index: self._jobs(spec, index, root) for index in indices}
            parts: dict[int, dict[int, PatientMetrics]] = {index: {} for index in indices}
            results: dict[int, PatientMetrics] = {}
            total = sum(len(shard) for shard in jobs.values())
            pool = ThreadPoolExecutor(min(self.parallel, total), thread_name_prefix='kit')
            pending: dict[Future, int] = {
                pool.submit(run, job): index for index, shard in jobs.items() for job in shard
            }
            try:
                while pending:
                    done, _ = wait(pending, return_when=FIRST_COMPLETED)
                    for future in done:
                        index = pending.pop(future)
                        run_ = future.result()
                        self.runs.append(run_)
                        if self.on_patient is not None:
                            self.on_patient(run_)
                        if not run_.success:
                            raise PatientError(run_)
                        parts[index][run_.patient] = patient_metrics(spec, run_.record)
                        if self.keep_records:
                            self.records[run_.patient] = patient_record(
                                spec, run_.patient, run_.record
                            )
                        if len(parts[index]) == len(jobs[index]):
                            start, stop = bounds[index]
                            results[index] = PatientMetrics.concatenate(
                                [parts[index][i] for i in range(start, stop)]
                            )
                            on_done(index, results[index])
            except BaseException:  # a failed patient, Ctrl-C: stop the gloves in flight
                for future in pending:
                    future.cancel()
                for worker in list(workers):
                    worker.close(at_once=True)
                raise
            finally:
                # Each worker stops its glove and exits before its pool thread ends: a worker
                # gets SIGINT when the thread that started it ends (Child's parent-death signal).
                # All are told first, so that they stop their gloves at once.
                for worker in workers:
                    worker.end()
                for worker in workers:
                    worker.close()
                pool.shutdown(wait=True)
        return [results[index] for index in indices]

    def session(self, spec: TrialSpec, patient: int) -> PatientRecord:
        """Patient ``patient``'s session run again on a glove of its own.

        For a report's figure of a trial whose engine kept no records (a Ray run of
        :func:`kit_shard`): the same patient, protocol and controller, so the same session.

        Raises
        ------
        PatientError
            When the run fails.
        """
        index = patient // spec.shard_size
        with tempfile.TemporaryDirectory(prefix='exodigit_kit_trial_') as scratch:
            root = Path(scratch) if self.log_dir is None else self.log_dir
            job = next(j for j in self._jobs(spec, index, root) if j.patient == patient)
            worker = Worker()
            try:
                run = worker.run(job)
            finally:
                worker.close()
        if not run.success:
            raise PatientError(run)
        return patient_record(spec, patient, run.record)

    def _jobs(self, spec: TrialSpec, index: int, root: Path) -> list[PatientJob]:
        """Shard ``index``'s patients as jobs, each with its parameter file written."""
        patients = shard_patients(spec, index)
        start = shard_bounds(spec)[index][0]
        glove = spec.glove_params()
        protocol = spec.session()
        trajectory = protocol.trajectory()
        command = tuple(spec.controller.command())
        parameters = dict(spec.controller.parameters)
        jobs = []
        for offset, finger in enumerate(patients.fingers):
            patient = start + offset
            folder = root / f'patient_{patient}'
            folder.mkdir(parents=True, exist_ok=True)
            params_file = folder / 'patient.yaml'
            dump_params(replace(glove, finger=finger), params_file)
            jobs.append(
                PatientJob(
                    patient,
                    str(params_file),
                    plant_parameters(spec, patient),
                    command,
                    parameters,
                    trajectory,
                    protocol.duration,
                    self.follows_targets,
                    self.timeout,
                    str(folder),
                    self.fresh_nodes,
                )
            )
        return jobs
