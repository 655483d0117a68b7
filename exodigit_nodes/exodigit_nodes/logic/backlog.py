"""Taking what a reader still holds when the nodes it listens to have stopped (no ROS).

A recorder or a monitor that fell behind on a loaded machine holds seconds of the nodes' last
messages in its readers when they stop (fresh clone fc54: a run record ended 5 s before the
zero pressure that the command node sends as it stops). Before it closes its record, it takes
them: it spins until several passes in a row take nothing.
"""

import time
from collections.abc import Callable

BACKLOG_LIMIT = 10.0
"""Longest time a reader's backlog is taken for, s."""
EMPTY_PASSES = 5
"""Passes in a row that take nothing before the backlog counts as taken. A pass may handle
something that is not a message (the graph event of a node that has just left) while messages
still wait behind it: stopping at the first such pass, a run record's drain took 222 of the 900
messages its readers held (beside two busy cores)."""


def take_backlog(
    spin: Callable[[], None], taken: Callable[[], int], limit: float = BACKLOG_LIMIT
) -> int:
    """Call ``spin`` (an executor pass) until `EMPTY_PASSES` in a row take nothing, or ``limit`` s.

    ``taken`` counts the messages taken so far. Returns how many the passes took.
    """
    first = taken()
    deadline = time.monotonic() + limit
    empty = 0
    while empty < EMPTY_PASSES and time.monotonic() < deadline:
        before = taken()
        spin()
        empty = empty + 1 if taken() == before else 0
    return taken() - first
