"""Command watchdog: says when the last valid command is older than a timeout."""

from __future__ import annotations

import math


class Watchdog:
    """Tracks the age of the last valid input.

    Parameters
    ----------
    timeout : float
        Age (s) after which the input counts as missing; > 0.

    Attributes
    ----------
    tripped : bool
        The input went missing at the latest :meth:`update` (and has not come back since).
    trips : int
        How many times the input went from fresh to missing.
    """

    def __init__(self, timeout: float) -> None:
        self.timeout = timeout
        self.last_feed: float | None = None
        self.trips = 0
        self.tripped = False

    def feed(self, now: float) -> bool:
        """Record a valid input at time ``now`` (s); True if it ends a trip."""
        restored = self.tripped
        self.last_feed = now
        self.tripped = False
        return restored

    def clear(self) -> None:
        """Forget the last input (as if none had ever come)."""
        self.last_feed = None
        self.tripped = False

    def age(self, now: float) -> float:
        """Seconds since the last input (inf if none yet)."""
        return math.inf if self.last_feed is None else now - self.last_feed

    def missing(self, now: float) -> bool:
        """Whether the input is missing at ``now`` (none yet, or older than the timeout)."""
        return self.age(now) > self.timeout

    def update(self, now: float) -> bool:
        """Advance to ``now``: True exactly when the input has just gone missing (a new trip)."""
        tripped = self.last_feed is not None and self.missing(now)
        new_trip = tripped and not self.tripped
        self.trips += new_trip
        self.tripped = tripped
        return new_trip
