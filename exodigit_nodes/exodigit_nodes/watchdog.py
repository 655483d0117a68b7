"""Command watchdog: says when the last valid command is older than a timeout."""

from __future__ import annotations

import math


class Watchdog:
    """Tracks the age of the last valid input.

    Parameters
    ----------
    timeout : float
        Age (s) after which the input counts as missing; > 0.
    """

    def __init__(self, timeout: float) -> None:
        self.timeout = timeout
        self.last_feed: float | None = None
        self.trips = 0
        self.tripped = False

    def feed(self, now: float) -> None:
        """Record a valid input at time ``now`` (s)."""
        self.last_feed = now
        self.tripped = False

    def clear(self) -> None:
        """Forget the last input (as if none had ever come)."""
        self.last_feed = None
        self.tripped = False

    def age(self, now: float) -> float:
        """Seconds since the last input (inf if none yet)."""
        return math.inf if self.last_feed is None else now - self.last_feed

    def expired(self, now: float) -> bool:
        """Whether the input is missing at ``now``; counts each fresh → missing transition."""
        missing = self.age(now) > self.timeout
        if missing and not self.tripped and self.last_feed is not None:
            self.trips += 1
        self.tripped = missing and self.last_feed is not None
        return missing
