"""The worker processes of a ROS node trial: one glove each, one patient at a time, driven apart.

:class:`~.trial_engine.KitEngine` runs each glove it has in flight through a :class:`Worker`, a
process of its own (``python -m exodigit_nodes.testing.trial_worker``) that reads pickled
:class:`PatientJob`s on its standard input, runs each on its :class:`WorkerGlove` and writes the
:class:`PatientRun` back on its standard output. The glove, with the controller node, is kept
from one patient to the next: each run is a new session of its plant (docs/trials.md, "A ROS node
as the controller"). A process of its own shares no interpreter lock; plain subprocesses, not
:mod:`multiprocessing`'s, so a script that runs a trial needs no
``if __name__ == '__main__'`` guard.
"""

from __future__ import annotations

import contextlib
import os
import pickle
import sys
import time
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from exodigit_model.control import Trajectory

from ..runner.supervisor import Child
from .client import GloveSimError
from .target_run import TargetGloveSim, TargetRecord

WORKER_STOP = 10.0
"""How long a worker may take to stop its glove and exit, at each step of its stop, s."""


@dataclass(frozen=True)
class PatientJob:
    """What a worker needs to run one patient's glove (picklable).

    ``trajectory``: the protocol's targets, one point a step, run for ``seconds``. ``fresh``:
    start a glove and the controller for this patient and stop them after it (for a node that
    does not start over when simulated time goes back), instead of the worker's glove.
    ``log_dir`` is where a glove started for this patient writes its nodes' output.
    """

    patient: int
    params_file: str
    plant: Mapping[str, Any]
    command: tuple[str, ...]
    parameters: Mapping[str, Any]
    trajectory: Trajectory
    seconds: float
    follows: bool
    timeout: float
    log_dir: str
    fresh: bool


@dataclass(frozen=True)
class PatientRun:
    """One patient's glove run, in the manner of a solver's result.

    Attributes
    ----------
    patient : int
        The patient's index in the trial.
    status : int
        0: the session ran; 1: it failed (the message says why: the controller exited, or it
        or the plant did not go on within the timeout).
    message : str
        One line.
    record : TargetRecord or None
        The session (None when it failed).
    wall_s : float
        Wall time of the run, s: the session, and the start and stop of a glove started for
        it.
    """

    patient: int
    status: int
    message: str
    record: TargetRecord | None = field(default=None, repr=False)
    wall_s: float = 0.0

    @property
    def success(self) -> bool:
        """Whether the session ran."""
        return self.status == 0


class WorkerGlove:
    """A worker's glove and controller node, kept from one patient to the next.

    A job's patient runs on the glove of the patient before: its plant is set to the patient
    (:meth:`~.client.GloveSim.set_patient`) and the run starts a new session of it, on which
    the node starts over. A glove and the node are started for the first job, after a failed
    one (which stops them), and for every ``fresh`` job (stopped after it).
    """

    def __init__(self) -> None:
        self.glove: TargetGloveSim | None = None

    def run(self, job: PatientJob) -> PatientRun:
        """``job``'s session; never raises for a failing controller or glove (``status`` 1)."""
        started = time.monotonic()
        try:
            glove = self._glove(job)
            record = glove.run_trajectory(job.trajectory, job.seconds, follows=job.follows)
        except (GloveSimError, ValueError) as error:
            self.close()
            wall = time.monotonic() - started
            return PatientRun(job.patient, 1, f'patient {job.patient}: {error}', None, wall)
        if job.fresh:
            self.close()
        wall = time.monotonic() - started
        steps = len(record.t)
        message = f'patient {job.patient}: {steps} steps in {wall:.1f} s'
        return PatientRun(job.patient, 0, message, record, wall)

    def _glove(self, job: PatientJob) -> TargetGloveSim:
        """The glove set to ``job``'s patient, started with the controller if need be."""
        if self.glove is not None and not job.fresh:
            self.glove.set_patient(job.params_file, job.plant)
            return self.glove
        self.close()
        self.glove = TargetGloveSim(
            job.params_file, plant=job.plant, timeout=job.timeout, log_dir=job.log_dir
        )
        self.glove.start_controller(job.command, job.parameters)
        return self.glove

    def close(self) -> None:
        """Stop the controller and the glove, if any (idempotent)."""
        if self.glove is not None:
            self.glove.close()
            self.glove = None


class Worker:
    """A worker process that runs the jobs it is sent on its glove, one at a time.

    A :class:`~exodigit_nodes.runner.supervisor.Child`: a session of its own (Ctrl-C reaches
    the engine, which stops the workers), SIGINT if the engine dies, SIGINT-SIGTERM-SIGKILL to
    stop.
    """

    def __init__(self) -> None:
        self.child = Child(
            'trial worker', [sys.executable, '-m', __name__], os.environ, pipes=True
        )

    def run(self, job: PatientJob) -> PatientRun:
        """``job`` run in the worker; a worker that dies is ``status`` 1."""
        started = time.monotonic()
        process = self.child.popen
        try:
            pickle.dump(job, process.stdin)
            process.stdin.flush()
            return pickle.load(process.stdout)
        except (OSError, EOFError, pickle.UnpicklingError):
            code = self.child.wait()
            return PatientRun(
                job.patient,
                1,
                f"patient {job.patient}: the kit's worker process ended (code {code}); node "
                f'logs in the patient folders of {Path(job.log_dir).parent}',
                None,
                time.monotonic() - started,
            )

    def end(self) -> None:
        """No more jobs: it stops its glove and exits after the current one (see :meth:`close`)."""
        with contextlib.suppress(OSError):
            self.child.popen.stdin.close()

    def close(self, *, at_once: bool = False) -> None:
        """End the worker: no more jobs, then SIGINT (it stops its glove), SIGTERM, SIGKILL.

        Without more jobs it exits after the current one; SIGINT comes after
        :data:`WORKER_STOP`, or at once with ``at_once``.
        """
        self.end()
        if at_once or self.child.wait(WORKER_STOP) is None:
            self.child.stop(grace=WORKER_STOP)
        self.child.popen.stdout.close()


def worker_main() -> None:
    """A worker: read pickled :class:`PatientJob`s on stdin, write :class:`PatientRun`s.

    Standard output is the results' channel only: what anything else prints goes to stderr.
    """
    results = os.fdopen(os.dup(1), 'wb')
    os.dup2(2, 1)
    jobs = sys.stdin.buffer
    glove = WorkerGlove()
    try:
        while True:
            try:
                job = pickle.load(jobs)
            except EOFError:
                return
            pickle.dump(glove.run(job), results)
            results.flush()
    except KeyboardInterrupt:  # the engine stops us
        return
    finally:
        glove.close()


if __name__ == '__main__':
    # the module by its name, so that what a worker pickles unpickles in the engine
    from exodigit_nodes.testing.trial_worker import worker_main as main

    main()
