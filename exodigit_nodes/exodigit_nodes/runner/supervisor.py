"""Start node processes, watch them, and stop them in a given order.

Each node runs as its own OS process in its own session (process group), so a Ctrl-C on the
terminal reaches only the supervisor, which then stops the nodes one by one with SIGINT (the
signal rclpy turns into a clean shutdown). Plain Python, no ROS: the glove command uses it, and
tests can use it for any command line.
"""

import contextlib
import os
import signal
import subprocess
import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path

from ..logic.lifetime import stop_with_parent

#: Seconds a process gets to exit after SIGINT before it is sent SIGTERM, then SIGKILL.
STOP_GRACE = 5.0
#: Seconds between two checks while waiting for processes to exit.
POLL_INTERVAL = 0.05


@dataclass(frozen=True)
class Exit:
    """How a supervised process ended.

    Attributes
    ----------
    name : str
        Process name given to `Supervisor.start`.
    returncode : int
        Exit code; negative for death by a signal (``-9`` = SIGKILL), as in `subprocess`.
    forced : bool
        True when it ignored SIGINT for `STOP_GRACE` seconds and had to be terminated.
    """

    name: str
    returncode: int
    forced: bool = False

    @property
    def clean(self) -> bool:
        """True for a stop as asked, never when it had to be forced.

        Exit code 0, or death by the SIGINT itself: a process still starting (before it took
        over SIGINT) ends that way.
        """
        return self.returncode in (0, -signal.SIGINT) and not self.forced

    def describe(self) -> str:
        """One human line, e.g. ``plant exited with code 1`` or ``plant killed by SIGKILL``."""
        if self.returncode < 0:
            text = f'{self.name} killed by {signal.Signals(-self.returncode).name}'
        else:
            text = f'{self.name} exited with code {self.returncode}'
        return text + (' (did not stop on SIGINT)' if self.forced else '')


def _child_setup(parent: int) -> Callable[[], None]:
    """A pre-exec hook: SIGINT acts in the child, and reaches it if ``parent`` dies.

    A shell starts background commands with SIGINT ignored, and an ignored signal stays ignored
    across exec: a node still starting (before it installs its own handler) would then sit out
    the supervisor's SIGINT. The disposition is reset to the default here.

    The children run in their own sessions, so neither a terminal hang-up nor a killed
    supervisor would otherwise reach them: on Linux they get SIGINT when ``parent`` dies, even by
    SIGKILL, instead of running on with nobody watching.
    """

    def hook() -> None:
        signal.signal(signal.SIGINT, signal.SIG_DFL)
        if not stop_with_parent(signal.SIGINT, parent):  # it died before the hook ran
            os._exit(1)

    return hook


class Supervisor:
    """A set of named child processes, each in its own session.

    Parameters
    ----------
    env : Mapping[str, str]
        Environment of every child (the caller's, with the ROS discovery settings).
    log_dir : pathlib.Path or None
        When given, each child's stdout and stderr go to ``log_dir/<name>.log`` instead of the
        terminal (so a live display is not interleaved with node logs).

    Notes
    -----
    On Linux each child is sent SIGINT if the supervising process dies. Start the children
    before this process starts threads (the pre-exec hook is not thread-safe).
    """

    def __init__(self, env: Mapping[str, str], log_dir: Path | None = None):
        self._env = dict(env)
        self._log_dir = log_dir
        self._processes: dict[str, subprocess.Popen] = {}
        self._exits: dict[str, Exit] = {}

    def start(self, name: str, argv: Sequence[str]) -> None:
        """Start ``argv`` as process ``name`` in a new session."""
        if name in self._processes:
            raise ValueError(f'a process named {name!r} was already started')
        log = self.log_path(name)
        if log is None:
            self._processes[name] = self._spawn(argv, None)
            return
        log.parent.mkdir(parents=True, exist_ok=True)
        with open(log, 'wb') as output:  # the child keeps its own copy of the descriptor
            self._processes[name] = self._spawn(argv, output)

    def _spawn(self, argv: Sequence[str], output) -> subprocess.Popen:
        return subprocess.Popen(
            list(argv),
            env=self._env,
            stdin=subprocess.DEVNULL,
            stdout=output,
            stderr=None if output is None else subprocess.STDOUT,
            start_new_session=True,
            preexec_fn=_child_setup(os.getpid()),
        )

    def log_path(self, name: str) -> Path | None:
        """Where the output of process ``name`` goes (None: the terminal)."""
        return None if self._log_dir is None else self._log_dir / f'{name}.log'

    def pid(self, name: str) -> int:
        """Process id of ``name`` (also its process group id)."""
        return self._processes[name].pid

    @property
    def names(self) -> list[str]:
        """Names of all started processes, in start order."""
        return list(self._processes)

    def exited(self) -> list[Exit]:
        """Processes that have ended since they were started (without being asked to stop)."""
        return [self._reap(name) for name in self._processes if self._poll(name) is not None]

    def running(self) -> list[str]:
        """Names of the processes still alive."""
        return [name for name in self._processes if self._poll(name) is None]

    def stop(
        self,
        order: Sequence[str],
        idle: Callable[[], None] | None = None,
        grace: float = STOP_GRACE,
    ) -> list[Exit]:
        """Stop the processes one after the other, in ``order``, then any others left.

        Each gets SIGINT (sent to its whole process group) and ``grace`` seconds to exit, then
        SIGTERM and, after another ``grace``, SIGKILL. ``idle`` is called while waiting (e.g. to
        keep a ROS monitor spinning so it sees the last messages).

        Returns
        -------
        list of Exit
            One per process, in stop order.
        """
        names = list(order) + [name for name in self._processes if name not in order]
        return [self._stop_one(name, idle, grace) for name in names if name in self._processes]

    def _stop_one(self, name: str, idle: Callable[[], None] | None, grace: float) -> Exit:
        if name in self._exits:
            return self._exits[name]  # stopped (or seen dead) before
        forced = False
        for sig in (signal.SIGINT, signal.SIGTERM, signal.SIGKILL):
            if self._poll(name) is not None:
                break
            forced = sig != signal.SIGINT
            self._signal_group(name, sig)
            deadline = time.monotonic() + grace
            while self._poll(name) is None and time.monotonic() < deadline:
                if idle is not None:
                    idle()
                else:
                    time.sleep(POLL_INTERVAL)
        self._processes[name].wait()
        # Children the node may have started itself go with its group.
        self._signal_group(name, signal.SIGKILL)
        exit_ = self._reap(name)
        if forced:
            exit_ = Exit(name, exit_.returncode, forced=True)
            self._exits[name] = exit_
        return exit_

    def _signal_group(self, name: str, sig: signal.Signals) -> None:
        with contextlib.suppress(ProcessLookupError):
            os.killpg(self._processes[name].pid, sig)

    def _poll(self, name: str) -> int | None:
        return self._processes[name].poll()

    def _reap(self, name: str) -> Exit:
        if name not in self._exits:
            self._exits[name] = Exit(name, self._processes[name].returncode)
        return self._exits[name]
