"""Taking what a reader still holds when the nodes it listens to have stopped (no ROS).

A recorder or a monitor that fell behind on a loaded machine holds seconds of the nodes' last
messages in its readers when they stop (fresh clone fc54: a run record ended 5 s before the
zero pressure that the command node sends as it stops). Before it closes its record, it takes
them: it spins until a pass takes nothing.
"""

import time
from collections.abc import Callable

BACKLOG_LIMIT = 10.0
"""Longest time a reader's backlog is taken for, s."""


def take_backlog(
    spin: Callable[[], None], taken: Callable[[], int], limit: float = BACKLOG_LIMIT
) -> int:
    """Call ``spin`` (one pass of an executor) until a pass takes nothing, or for ``limit`` s.

    ``taken`` counts the messages taken so far. Returns how many the passes took.
    """
    first = taken()
    deadline = time.monotonic() + limit
    while time.monotonic() < deadline:
        before = taken()
        spin()
        if taken() == before:
            break
    return taken() - first
