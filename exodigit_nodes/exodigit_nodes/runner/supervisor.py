"""Start child processes, watch them, and stop them in a given order (plain Python, no ROS).

Each child runs in a process group of its own, so a Ctrl-C on the terminal reaches only the
runner, which stops the children one by one. A stop escalates as ``ros2 launch`` does:
SIGINT, after ``grace`` s SIGTERM, after another ``grace`` SIGKILL; then the child's whole group
is killed. A child gets SIGINT when the process that started it dies
(:func:`..logic.lifetime.stop_with_parent`). The runners use :class:`Supervisor`, the testing
kit :class:`Child`.
"""

from __future__ import annotations

import contextlib
import os
import signal
import subprocess
import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path

from ..logic.lifetime import STOP_SIGNALS, exit_status, stop_with_parent

#: Seconds a process gets after SIGINT, then after SIGTERM (as ``ros2 launch``'s default).
STOP_GRACE = 5.0
#: The escalation of a stop, in order.
ESCALATION = (signal.SIGINT, signal.SIGTERM, signal.SIGKILL)


@dataclass(frozen=True)
class Exit:
    """How a supervised process ended.

    Attributes
    ----------
    name : str
        Process name.
    returncode : int
        Exit code; negative for death by a signal (``-9`` = SIGKILL), as in `subprocess`.
    forced : bool
        True when it ignored SIGINT for the grace time and had to be terminated.
    """

    name: str
    returncode: int
    forced: bool = False

    @property
    def clean(self) -> bool:
        """Exit code 0 or death by SIGINT (a process still starting), never when forced."""
        return self.returncode in (0, -signal.SIGINT) and not self.forced

    def describe(self) -> str:
        """One human line, e.g. ``plant exited with code 1`` or ``plant was killed by SIGKILL``."""
        text = f'{self.name} {exit_status(self.returncode)}'
        return text + (' (did not stop on SIGINT)' if self.forced else '')


def _child_setup(parent: int, *, defer_sigint: bool) -> Callable[[], None]:
    """A pre-exec hook: SIGINT acts in the child, and reaches it if ``parent`` dies.

    SIGINT's disposition is reset to the default (a shell starts background commands with it
    ignored, which exec keeps) and the stop signals are unblocked (a Ray worker blocks them, and
    its children inherit that). With ``defer_sigint`` SIGINT is blocked instead, for a child
    whose :class:`~exodigit_nodes.logic.lifetime.StopRequest` unblocks it: a SIGINT during its
    imports waits for that, where a KeyboardInterrupt could be swallowed by import code.
    """

    def hook() -> None:
        signal.signal(signal.SIGINT, signal.SIG_DFL)
        signal.pthread_sigmask(signal.SIG_UNBLOCK, STOP_SIGNALS)
        if defer_sigint:
            signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGINT})
        if not stop_with_parent(signal.SIGINT, parent):  # it died before the hook ran
            os._exit(1)

    return hook


class Child:
    """One child process in a session of its own, with its output in log files.

    Parameters
    ----------
    name : str
        Its name in messages and :class:`Exit`.
    argv : sequence of str
        Command line.
    env : mapping
        Its environment.
    log : pathlib.Path or None
        Where its stdout goes (and its stderr unless ``errors`` is given); None: the terminal.
    errors : pathlib.Path or None
        A separate file for its stderr.
    cwd : pathlib.Path or None
        Working directory (default this process's).
    defer_sigint : bool
        The command handles SIGINT with a :class:`~exodigit_nodes.logic.lifetime.StopRequest`
        (every exodigit node and runner): SIGINT is held until it does.
    pipes : bool
        Its standard input and output are pipes (``popen.stdin``, ``popen.stdout``); its stderr
        still goes to ``errors`` or ``log``. Otherwise its standard input is empty.

    Notes
    -----
    Start children before this process starts threads (the pre-exec hook is not thread-safe),
    or from a thread that outlives them (the parent-death signal follows the starting thread).
    """

    def __init__(
        self,
        name: str,
        argv: Sequence[str],
        env: Mapping[str, str],
        log: Path | None = None,
        errors: Path | None = None,
        cwd: Path | None = None,
        *,
        defer_sigint: bool = False,
        pipes: bool = False,
    ) -> None:
        self.name = name
        self.log_path = log
        self.errors_path = errors
        with contextlib.ExitStack() as files:  # the child keeps its own copies
            out = err = None
            if log is not None:
                log.parent.mkdir(parents=True, exist_ok=True)
                out = files.enter_context(open(log, 'wb'))
                err = subprocess.STDOUT
            if errors is not None:
                errors.parent.mkdir(parents=True, exist_ok=True)
                err = files.enter_context(open(errors, 'wb'))
            if pipes:
                out, err = subprocess.PIPE, out if err is subprocess.STDOUT else err
            self.popen = subprocess.Popen(
                list(argv),
                cwd=cwd,
                env=dict(env),
                stdin=subprocess.PIPE if pipes else subprocess.DEVNULL,
                stdout=out,
                stderr=err,
                start_new_session=True,
                preexec_fn=_child_setup(os.getpid(), defer_sigint=defer_sigint),
            )
        self.pid = self.popen.pid
        """Its process id, also its process group's."""
        self._exit: Exit | None = None

    def alive(self) -> bool:
        """Whether it is still running."""
        return self.popen.poll() is None

    def signal(self, signum: int) -> None:
        """Send ``signum`` to its process group (nothing once it has been reaped)."""
        if self.alive():
            with contextlib.suppress(ProcessLookupError):
                os.killpg(self.pid, signum)

    def wait(self, timeout: float | None = None) -> int | None:
        """Its exit code, or None if it still runs after ``timeout`` s (None: wait for ever)."""
        try:
            return self.popen.wait(timeout)
        except subprocess.TimeoutExpired:
            return None

    def exit(self) -> Exit | None:
        """How it ended (None while it runs)."""
        if self._exit is None and not self.alive():
            self._exit = Exit(self.name, self.popen.returncode)
        return self._exit

    def stop(self, grace: float = STOP_GRACE, idle: Callable[[], None] | None = None) -> Exit:
        """Stop it: SIGINT, then SIGTERM and SIGKILL each after ``grace`` s; how it ended.

        ``idle`` is called while waiting (e.g. to keep a ROS monitor spinning so it sees the last
        messages). A child that ended before is not signalled, and its :class:`Exit` returned.
        """
        if self.exit() is not None:
            return self._exit
        forced = False
        for signum in ESCALATION:
            if not self.alive():
                break
            forced = signum != signal.SIGINT
            self.signal(signum)
            deadline = time.monotonic() + grace
            while self.alive() and (left := deadline - time.monotonic()) > 0:
                if idle is None:
                    self.wait(left)
                else:
                    idle()
        self.popen.wait()
        with contextlib.suppress(ProcessLookupError):
            os.killpg(self.pid, signal.SIGKILL)
        self._exit = Exit(self.name, self.popen.returncode, forced=forced)
        return self._exit

    def kill(self) -> Exit:
        """SIGKILL its group at once (fault tests); how it ended."""
        self.signal(signal.SIGKILL)
        self.popen.wait()
        return self.exit()


class Supervisor:
    """A set of named child processes, each a :class:`Child`.

    Parameters
    ----------
    env : Mapping[str, str]
        Environment of every child (the caller's, with the ROS discovery settings).
    log_dir : pathlib.Path or None
        When given, each child's stdout and stderr go to ``log_dir/<name>.log`` instead of the
        terminal (so a live display is not interleaved with node logs).

    Attributes
    ----------
    children : dict of str to Child
        The processes started, by name, in start order.
    """

    def __init__(self, env: Mapping[str, str], log_dir: Path | None = None) -> None:
        self._env = dict(env)
        self._log_dir = log_dir
        self.children: dict[str, Child] = {}

    def start(self, name: str, argv: Sequence[str], *, defer_sigint: bool = False) -> None:
        """Start ``argv`` as process ``name`` in a new session (``defer_sigint``: see Child)."""
        if name in self.children:
            raise ValueError(f'a process named {name!r} was already started')
        log = None if self._log_dir is None else self._log_dir / f'{name}.log'
        self.children[name] = Child(name, argv, self._env, log, defer_sigint=defer_sigint)

    def exited(self) -> list[Exit]:
        """Processes that have ended since they were started (without being asked to stop)."""
        return [exit_ for child in self.children.values() if (exit_ := child.exit())]

    def running(self) -> list[str]:
        """Names of the processes still alive."""
        return [name for name, child in self.children.items() if child.alive()]

    def stop(
        self,
        order: Sequence[str],
        idle: Callable[[], None] | None = None,
        grace: float = STOP_GRACE,
    ) -> list[Exit]:
        """Stop the processes one by one (:meth:`Child.stop`), in ``order``, then the others.

        Returns
        -------
        list of Exit
            One per process, in stop order.
        """
        names = [name for name in order if name in self.children]
        names += [name for name in self.children if name not in names]
        return [self.children[name].stop(grace, idle) for name in names]
