"""A trial's shards as Ray tasks: on a local Ray instance bound to 127.0.0.1, or on a cluster.

docs/trials.md, "On a Ray cluster". :class:`RayEngine` is an :class:`~.trial.Engine`: each shard
is one Ray task running :func:`~.trial.run_shard` in a worker process, the results come back in
the order of the indices, and ``on_done`` is called as each task finishes. A shard's result
depends on the spec and its index only, so the per-patient results are those of
:class:`~.trial.LocalEngine`, bit for bit.

Ray (the ``ray`` extra, ``pip install "./exodigit_model[ray]"``) is imported when an engine is
made, never by ``exodigit_model`` itself.

Where the workers come from
---------------------------
- ``RayEngine()`` starts a Ray instance on this machine and stops it on :meth:`RayEngine.close`.
  Every server of it (the GCS, the raylet, the workers' and the driver's gRPC servers, the
  runtime-env agent) listens on 127.0.0.1 only, and there is no dashboard. Ray turns a node
  address of 127.0.0.1 into the machine's reachable address unless
  ``RAY_ENABLE_WINDOWS_OR_OSX_CLUSTER=0`` when it is imported (its single-machine mode, the
  default on macOS and Windows), so the engine sets that before importing Ray, and refuses to
  start when Ray was imported earlier without it. Ray's usage statistics are off
  (``RAY_USAGE_STATS_ENABLED=0`` unless set).
- ``RayEngine(address)`` connects to a running cluster (``'auto'`` for the one ``ray start``
  made on this machine, or ``'host:port'`` of its head) and disconnects on close: the
  cluster runs on.
- Ray allows one connection per process: when Ray is already initialized (by the caller or
  another engine), the engine uses that connection, starts nothing and leaves it open.

The workers import ``exodigit_model`` from their own Python environment: that of this process
for a local instance, that of ``ray start`` on each node of a cluster. They inherit their
environment too, so they use the same numba kernel cache (``NUMBA_CACHE_DIR`` or the package's
own, :mod:`exodigit_model.kernels.jit`) as this process on this machine.
"""

from __future__ import annotations

import importlib
import os
import sys
from collections.abc import Callable, Sequence
from types import ModuleType
from typing import Any

from .metrics import PatientMetrics
from .spec import TrialSpec
from .trial import OnDone, run_shard, shard_bounds

LOOPBACK = '127.0.0.1'
"""The only address a local instance listens on."""

INSTALL_HINT = 'pip install "./exodigit_model[ray]"'
"""What a user runs to get Ray."""

SINGLE_MACHINE = 'RAY_ENABLE_WINDOWS_OR_OSX_CLUSTER'
"""Ray's switch of its single-machine mode, read once when Ray is imported: '0' keeps a node
address of 127.0.0.1 (Ray resolves it to the machine's reachable address otherwise)."""


class ShardError(RuntimeError):
    """A shard failed on a Ray worker.

    The message names the shard, its patients and the error; the error Ray raised (with the
    worker's traceback) is chained as ``__cause__``.

    Attributes
    ----------
    index : int
        The shard.
    patients : tuple of int
        Its patients, ``(a, b)``: a ≤ i < b.
    """

    def __init__(self, index: int, patients: tuple[int, int], reason: str) -> None:
        self.index = index
        self.patients = patients
        super().__init__(
            f'shard {index} (patients {patients[0]} … {patients[1] - 1}) failed on Ray: {reason}'
        )


class RayEngine:
    """Runs a trial's shards as Ray tasks (module docstring).

    Parameters
    ----------
    address : str, optional
        A running cluster to connect to (``ray.init(address=...)``: ``'auto'``, or
        ``'host:port'`` of its head). None (default): start a Ray instance on this machine,
        bound to 127.0.0.1, for as long as the engine is open.
    workers : int, optional
        How many shards run at once (≥ 1), one worker process each; for the instance the engine
        starts, also its CPUs, so its worker processes. None (default): every CPU of the
        machine, or of the cluster.
    shard : callable, optional
        What a task runs, ``shard(spec, index) -> PatientMetrics`` (picklable: a module-level
        function or a ``functools.partial`` of one): :func:`~.trial.run_shard` by default;
        ``exodigit_nodes.testing.trial_engine.kit_shard`` spreads a ROS node controller's
        gloves over the cluster's nodes.

    Raises
    ------
    ModuleNotFoundError
        Without Ray, naming the extra to install.
    ValueError
        For a bad ``workers``, or an ``address`` while Ray is already initialized.
    RuntimeError
        When a local instance cannot be kept on 127.0.0.1 (Ray imported before the engine).

    Examples
    --------
    >>> from exodigit_model.trials import TrialSpec, run_trial
    >>> with RayEngine(workers=2) as engine:                     # doctest: +SKIP
    ...     result = run_trial(TrialSpec(patients=10_000), engine=engine)
    """

    def __init__(
        self,
        address: str | None = None,
        *,
        workers: int | None = None,
        shard: Callable[[TrialSpec, int], PatientMetrics] = run_shard,
    ) -> None:
        if workers is not None and (
            isinstance(workers, bool) or not isinstance(workers, int) or workers < 1
        ):
            raise ValueError(f'workers = {workers!r}: must be a whole number >= 1 or None')
        self.workers = workers
        self._ray = import_ray(local=address is None)
        self._owned = not self._ray.is_initialized()
        if not self._owned:
            if address is not None:
                raise ValueError(
                    f'address = {address!r}: Ray is already initialized in this process '
                    '(one connection per process); give no address to use that connection'
                )
        elif address is None:
            self._start_local()
        else:
            self._ray.init(address=address)
        self._shard = shard
        self._task = self._ray.remote(num_cpus=1)(run_task)

    def _start_local(self) -> None:
        """Start a Ray instance on this machine whose servers listen on 127.0.0.1 only."""
        ray = self._ray
        if os.environ.get(SINGLE_MACHINE) != '0':
            raise RuntimeError(_loopback_refused('the reachable address'))
        os.environ.setdefault('RAY_USAGE_STATS_ENABLED', '0')
        ray.init(
            address='local',
            num_cpus=self.workers,
            include_dashboard=False,
            _node_ip_address=LOOPBACK,
        )
        if ray.util.get_node_ip_address() != LOOPBACK:
            ray.shutdown()
            raise RuntimeError(_loopback_refused(ray.util.get_node_ip_address()))

    def map(
        self, spec: TrialSpec, indices: Sequence[int], on_done: OnDone
    ) -> list[PatientMetrics]:
        """The engine's ``shard`` of every index as a Ray task; results in index order.

        At most ``workers`` tasks are in flight. ``on_done(index, metrics)`` is called in this
        process as each task finishes.

        Raises
        ------
        ShardError
            For the first shard found failed (the others are cancelled, their workers ended).
        """
        ray = self._ray
        bounds = shard_bounds(spec)
        shared = ray.put(spec)
        limit = self.workers or len(indices)
        pending: dict[Any, int] = {}
        results: list[PatientMetrics | None] = [None] * len(indices)
        queue = iter(range(len(indices)))

        def submit() -> None:
            position = next(queue, None)
            if position is not None:
                pending[self._task.remote(self._shard, shared, indices[position])] = position

        try:
            for _ in range(limit):
                submit()
            while pending:
                (ready,), _ = ray.wait(list(pending), num_returns=1)
                position = pending.pop(ready)
                index = indices[position]
                try:
                    part = ray.get(ready)
                except ray.exceptions.RayError as error:
                    raise ShardError(index, bounds[index], _reason(error)) from error
                # Ray may hand arrays back as read-only views of its shared-memory object
                # store, valid while Ray runs: keep copies that outlive close()
                results[position] = PatientMetrics.concatenate([part])
                on_done(index, results[position])
                submit()
        finally:
            # force: a running task's worker process is ended, not interrupted. Ray interrupts a
            # task with KeyboardInterrupt, which can land inside numba's registry loader while
            # the worker loads its first kernel; that worker then failed every later task
            # ("generator raised StopIteration", seen once in a full suite run).
            for reference in pending:
                ray.cancel(reference, force=True)
        return results

    def close(self) -> None:
        """Stop the instance the engine started, or disconnect from the cluster; idempotent.

        A connection the engine found open is left open.
        """
        if self._owned:
            self._owned = False
            self._ray.shutdown()

    def __enter__(self) -> RayEngine:
        return self

    def __exit__(self, *exc_info: object) -> None:
        self.close()


def run_task(
    shard: Callable[[TrialSpec, int], PatientMetrics], spec: TrialSpec, index: int
) -> PatientMetrics:
    """What a Ray task runs: ``shard(spec, index)``.

    Ray makes tasks of plain functions only, and an engine's ``shard`` may be a
    ``functools.partial``.
    """
    return shard(spec, index)


def import_ray(*, local: bool) -> ModuleType:
    """Ray; imported for a local instance (``local``) in its single-machine mode.

    Raises
    ------
    ModuleNotFoundError
        When Ray is not installed, naming the extra.
    """
    if local and 'ray' not in sys.modules:
        os.environ[SINGLE_MACHINE] = '0'
    try:
        return importlib.import_module('ray')
    except ModuleNotFoundError as error:
        if error.name != 'ray':
            raise
        raise ModuleNotFoundError(
            f'ray is not installed; the Ray engine needs the ray extra: {INSTALL_HINT}',
            name='ray',
        ) from None


def _loopback_refused(address: str) -> str:
    return (
        f'a local Ray instance would listen on {address}, not {LOOPBACK} only: Ray was imported '
        f'before the engine could set {SINGLE_MACHINE}=0; set it before importing ray, or '
        'start a cluster with ray start and give its address'
    )


def _reason(error: Exception) -> str:
    """What went wrong in a task, in one line: the task's own exception when it raised one."""
    cause = getattr(error, 'cause', None)
    if isinstance(cause, BaseException):
        return f'{type(cause).__name__}: {cause}'
    return f'{type(error).__name__}: {str(error).strip().splitlines()[0]}'
