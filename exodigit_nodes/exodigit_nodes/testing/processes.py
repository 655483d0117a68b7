"""Glove nodes as OS processes in a private ROS domain: what the testing kit and our tests share.

* :func:`claim_domain` picks a ROS_DOMAIN_ID nobody on this machine is using, held with ROS 2's
  ``domain_coordinator`` while it is in use (ids 1-100, skipping 37, the ``make run`` domain), so
  parallel test runs never cross-talk.
* :func:`ros_environment` is the environment of a ROS child process: that domain, and discovery
  kept on this machine (``ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST``).
* :class:`KitPlace` is a kit glove's domain, namespace and log folder together.
* :class:`NodeProcess` starts ``python -m exodigit_nodes.<node> --ros-args ...`` as the runners
  start theirs (:class:`..runner.supervisor.Child`: own session, output to log files, SIGINT then
  SIGTERM then SIGKILL to stop, SIGINT if the process that started it dies).
"""

from __future__ import annotations

import itertools
import os
import random
import sys
import tempfile
import time
from collections.abc import Mapping
from pathlib import Path
from typing import Any

from domain_coordinator import domain_id

from ..logic.ros_env import ros_args
from ..nodes.dds import with_profile
from ..runner.supervisor import STOP_GRACE, Child

_NAMESPACES = itertools.count(1)
"""Numbers of the fresh namespaces of this process's kit gloves."""
DOMAIN_IDS = tuple(i for i in range(1, 101) if i != 37)
"""Domain ids the kit and the tests may use (37 is the Makefile's ``make run`` domain)."""
STOP_TIMEOUT = 2.0
"""How long a glove node may take to exit after SIGINT, s: what the tests hold it to (the
supervisor waits longer, :data:`..runner.supervisor.STOP_GRACE`, before it escalates)."""


class DomainLease:
    """A ROS_DOMAIN_ID held for this process (domain_coordinator's port); release it when done."""

    def __init__(self, domain_id: int, hold) -> None:
        self.domain_id = domain_id
        self._hold = hold

    def release(self) -> None:
        """Give the domain id back (idempotent)."""
        if self._hold is not None:
            hold, self._hold = self._hold, None
            hold.__exit__(None, None, None)


def claim_domain(candidates=DOMAIN_IDS) -> DomainLease:
    """Hold a domain id of ``candidates`` nobody else on this machine holds (random order).

    :func:`domain_coordinator.domain_id` (ROS 2's own coordinator) holds an id by binding TCP
    port 32768 + id for as long as the lease lasts: any process on this machine that asks it,
    ours or another package's test run, gets another id, and the kernel frees the port when this
    process ends, however it ends. Its own choice counts up from 1, 37 included, so the ids are
    offered here, shuffled, from ``candidates``.
    """
    order = list(candidates)
    random.shuffle(order)
    offers = itertools.cycle(order)
    hold = domain_id(selector=lambda: next(offers))
    try:
        return DomainLease(hold.__enter__(), hold)
    except RuntimeError:  # all its tries (100) found the id's port taken
        raise RuntimeError(
            f'every test ROS domain id in {min(order)}..{max(order)} is in use'
        ) from None


def ros_environment(domain_id: int) -> dict[str, str]:
    """The environment of a ROS child process: ours, with its domain and loopback discovery."""
    env = dict(os.environ)
    env['ROS_DOMAIN_ID'] = str(domain_id)
    env['ROS_AUTOMATIC_DISCOVERY_RANGE'] = 'LOCALHOST'
    env.pop('ROS_LOCALHOST_ONLY', None)
    env['PYTHONUNBUFFERED'] = '1'
    return with_profile(env)


class KitPlace:
    """Where a kit's glove lives: a ROS domain, an absolute namespace, a folder for its logs.

    Parameters
    ----------
    prefix : str
        Stem of a fresh namespace (``/<prefix>_<pid>_<n>``) and of a temporary folder.
    namespace : str, optional
        Absolute namespace; a fresh one when omitted.
    domain_id : int, optional
        ROS_DOMAIN_ID; a free one is claimed (:func:`claim_domain`) and held until
        :meth:`close` when omitted.
    log_dir : str or Path, optional
        Where the processes' output goes; a temporary folder, removed at :meth:`close`, when
        omitted.

    Attributes
    ----------
    namespace : str
    domain_id : int
    env : dict
        The environment for a process of the glove's, or a controller of yours
        (:func:`ros_environment`: the domain, loopback-only discovery).
    log_dir : Path
    """

    def __init__(
        self,
        prefix: str,
        namespace: str | None = None,
        domain_id: int | None = None,
        log_dir: str | os.PathLike | None = None,
    ) -> None:
        self.namespace = namespace or f'/{prefix}_{os.getpid()}_{next(_NAMESPACES)}'
        if not self.namespace.startswith('/'):
            raise ValueError(f'namespace {self.namespace!r} must be absolute (start with /)')
        self._lease: DomainLease | None = None
        if domain_id is None:
            self._lease = claim_domain()
            domain_id = self._lease.domain_id
        self.domain_id = domain_id
        self.env = ros_environment(domain_id)
        self._temporary = None
        if log_dir is None:
            self._temporary = tempfile.TemporaryDirectory(prefix=f'{prefix}_')
            log_dir = self._temporary.name
        self.log_dir = Path(log_dir)
        self.log_dir.mkdir(parents=True, exist_ok=True)

    def close(self) -> None:
        """Release the domain and remove a temporary log folder (idempotent)."""
        if self._lease is not None:
            self._lease.release()
            self._lease = None
        if self._temporary is not None:
            self._temporary.cleanup()
            self._temporary = None


# -- node processes ------------------------------------------------------------------------


def cpu_seconds(pid: int) -> float:
    """User + system CPU time process ``pid`` has used so far, s (from /proc)."""
    fields = Path(f'/proc/{pid}/stat').read_text().rsplit(')', 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf('SC_CLK_TCK')


class NodeProcess(Child):
    """One node run as a user would: ``python -m exodigit_nodes.<module> --ros-args ...``.

    A :class:`~exodigit_nodes.runner.supervisor.Child` (own session, stop escalation, SIGINT
    when this process dies), its stdout and stderr in two files of ``workdir``.

    Parameters
    ----------
    module : str
        ``plant``, ``pressure_command``, ``estimator`` (any module of exodigit_nodes).
    parameters : mapping, optional
        ``-p`` overrides.
    domain_id : int
        ROS_DOMAIN_ID for the process.
    workdir : path
        Scratch directory: the working directory and where ``<label>.out/.err`` logs go.
    namespace, name : str, optional
        ``__ns`` and ``__node`` remaps.
    extra : list of str, optional
        More ROS arguments, placed before the overrides (e.g. ``['--params-file', path]``).
    arguments : list of str, optional
        The program's own arguments, before ``--ros-args`` (e.g. ``hand_nodes --fingers``).
    """

    def __init__(
        self,
        module: str,
        parameters: Mapping[str, Any] | None,
        domain_id: int,
        workdir: Path,
        namespace: str | None = None,
        name: str | None = None,
        extra: list[str] | None = None,
        arguments: list[str] | None = None,
    ) -> None:
        self.module = module
        workdir = Path(workdir)
        label = f'{module}{(namespace or "").replace("/", "_")}-{time.monotonic_ns()}'
        command = [sys.executable, '-m', f'exodigit_nodes.nodes.{module}', *(arguments or [])]
        command += ros_args(parameters, namespace, name, extra)
        super().__init__(
            module,
            command,
            ros_environment(domain_id),
            log=workdir / f'{label}.out',
            errors=workdir / f'{label}.err',
            cwd=workdir,
            defer_sigint=True,
        )
        self.stdout_path = self.log_path
        self.stderr_path = self.errors_path

    def stop(self, grace: float = STOP_GRACE, idle=None) -> int:
        """SIGINT, then SIGTERM and SIGKILL each after ``grace`` s; the exit status."""
        return super().stop(grace, idle).returncode

    def kill(self) -> int:
        """SIGKILL at once (fault tests); the exit status."""
        return super().kill().returncode

    def stderr(self) -> str:
        """What the node wrote on stderr so far."""
        return self.stderr_path.read_text(errors='replace')

    def stdout(self) -> str:
        """What the node wrote on stdout so far."""
        return self.stdout_path.read_text(errors='replace')

    def cpu_seconds(self) -> float:
        """User + system CPU time used so far, s (from /proc)."""
        return cpu_seconds(self.pid)

    def rss_bytes(self) -> int:
        """Resident memory now, bytes (from /proc)."""
        for line in Path(f'/proc/{self.pid}/status').read_text().splitlines():
            if line.startswith('VmRSS:'):
                return int(line.split()[1]) * 1024
        raise RuntimeError(f'no VmRSS for pid {self.pid}')
