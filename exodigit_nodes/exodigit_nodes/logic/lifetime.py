"""A glove process does not outlive the process that started it (Linux).

Whoever starts a node (``ros2 launch``, ``ros2 run``, the runners, the testing kit) may die
without stopping it: killed by SIGKILL, or ``ros2 launch`` sent SIGTERM alone. A node left
behind keeps the chambers pressurised in the simulation and keeps publishing into a domain the
next session may use. :func:`stop_with_parent` asks the kernel for a signal when the parent
dies (prctl PR_SET_PDEATHSIG); the node handles it as Ctrl-C, sending zero pressure first.

The signal comes when the *thread* that started the process ends: a program that starts nodes
from a worker thread must keep that thread alive while they run.
"""

import ctypes
import os
import signal
import sys

#: prctl(2) option: the signal a process gets when its parent dies.
PR_SET_PDEATHSIG = 1


def stop_with_parent(signum: int = signal.SIGINT, parent: int | None = None) -> bool:
    """Have ``signum`` sent to this process when its parent dies (Linux; elsewhere nothing).

    ``parent`` is the pid the parent had when it started this process (its current parent when
    omitted). Returns False when that parent is gone already, so no signal will come: the caller
    should stop at once.
    """
    if not sys.platform.startswith('linux'):
        return True
    if parent is None:
        parent = os.getppid()
    ctypes.CDLL(None, use_errno=True).prctl(PR_SET_PDEATHSIG, signum)
    return os.getppid() == parent
