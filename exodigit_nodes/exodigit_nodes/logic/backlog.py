"""Taking what a reader still holds when the nodes it listens to have stopped (no ROS).

A recorder or monitor behind on a loaded machine may hold seconds of the nodes' last messages
when they stop: it takes them before it closes its record (docs/spec/ros.md, "The session
protocol", guarantee 7).
"""

import time
from collections.abc import Callable

BACKLOG_LIMIT = 10.0
"""Longest time a reader's backlog is taken for, s."""
EMPTY_PASSES = 5
"""Passes in a row that take nothing before the backlog counts as taken: a pass may handle a
graph event (a node that has just left) while messages still wait behind it."""


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
