"""How a glove process stops: on a signal, with its parent, and how its end is told (no ROS).

A node must not outlive whoever started it (``ros2 launch``, the runners, the testing kit), even
one killed by SIGKILL: left behind, it would keep the chambers pressurised and keep publishing
into a domain the next session may use (docs/running.md, "Running the glove").
"""

import ctypes
import os
import signal
import sys

#: prctl(2) option: the signal a process gets when its parent dies.
PR_SET_PDEATHSIG = 1


def stop_with_parent(signum: int = signal.SIGINT, parent: int | None = None) -> bool:
    """Have ``signum`` sent to this process when its parent dies (Linux; elsewhere nothing).

    The signal comes when the *thread* that started the process ends: a program that starts
    nodes from a worker thread must keep that thread alive while they run. ``parent`` is the
    pid the parent had when it started this process (its current parent when omitted).
    Returns False when that parent is gone already, so no signal will come: stop at once.
    """
    if not sys.platform.startswith('linux'):
        return True
    if parent is None:
        parent = os.getppid()
    ctypes.CDLL(None, use_errno=True).prctl(PR_SET_PDEATHSIG, signum)
    return os.getppid() == parent


STOP_SIGNALS = (signal.SIGINT, signal.SIGTERM, signal.SIGHUP)
"""What asks a glove process to stop: Ctrl-C, ``kill``, and the terminal closing."""


class StopRequest:
    """Turns the stop signals into a flag a loop checks, created installed.

    No exception is thrown into what the process is doing (rclpy's C code, a half-written
    record): the loop sees :attr:`requested` and stops on its own.

    Attributes
    ----------
    requested : bool
        A stop signal has come.
    signal_name : str
        The name of the latest one (``'SIGINT'``), empty before.
    """

    def __init__(self) -> None:
        self.requested = False
        self.signal_name = ''
        self.install()

    def install(self) -> None:
        """Handle the stop signals (again: loading rclpy's C extension takes SIGINT over).

        Also when they were ignored (a shell's background command) or blocked (inherited from
        a Ray worker, or by the supervisor until now): a SIGINT that came meanwhile is handled.
        """
        for signum in STOP_SIGNALS:
            signal.signal(signum, self)
        signal.pthread_sigmask(signal.SIG_UNBLOCK, STOP_SIGNALS)

    def ignore(self) -> None:
        """Ignore the stop signals from now on (the process is stopping already)."""
        for signum in STOP_SIGNALS:
            signal.signal(signum, signal.SIG_IGN)

    def __call__(self, signum: int, _frame) -> None:
        """The signal handler: ask the loop to stop."""
        self.requested = True
        self.signal_name = signal.Signals(signum).name


def exit_status(returncode: int) -> str:
    """How a process ended, in words: ``exited with code 2``, ``was killed by SIGKILL``.

    ``returncode`` as :mod:`subprocess` and ``launch`` give it: negative for death by a signal.
    """
    if returncode >= 0:
        return f'exited with code {returncode}'
    try:
        return f'was killed by {signal.Signals(-returncode).name}'
    except ValueError:  # a number no signal of this system has
        return f'was killed by signal {-returncode}'
