"""The board's time on the host's clock, and the link's round trip (docs/spec/hardware.md).

:class:`BoardClock` maps a sample's board time (u32 µs, wrapping) to the host clock: the offset
host − board is the smallest seen over the samples (the one that waited least in buffers),
allowed to creep up by :data:`DRIFT` per second so that a board crystal slower than the host's
is followed. When the offset drops (a sample that waited less than every one before), the
stamps do not jump back: they advance at half the board's pace until they meet the new
offset. So stamps never decrease, and never lie after the sample's arrival (samples that
arrive together before the clock knows better may share their arrival as stamp).
:class:`HostClock` puts those host times on the system clock, which stamps ROS messages.
:class:`RoundTrip` measures, for each Openings sent, the time until the first
sample that says the board applies them.
"""

from __future__ import annotations

import math
import time
from collections import OrderedDict
from collections.abc import Callable

from .messages import BOARD_TIME_MODULO, SEQUENCE_MODULO

DRIFT = 200e-6
"""Largest clock rate difference followed, s/s (crystals: ±100 ppm each side)."""
CATCH_UP = 0.5
"""Least advance of a stamp per board second while the stamps catch up with a lower offset."""
TIGHT_READ_NS = 1_000_000
"""Longest time between the two monotonic reads around a system clock read that is trusted, ns."""
CLOCK_STEP_NS = 20_000_000
"""Change of the system clock's offset taken for the clock being set, not for jitter, ns."""
PENDING = 256
"""Openings remembered until a sample echoes them (older ones are forgotten)."""


class BoardClock:
    """Maps board times (µs, u32) to host times (s); :meth:`reset` at every new session."""

    def __init__(self) -> None:
        self.reset()

    def reset(self) -> None:
        """Forget the board's time (a new Hello restarts it)."""
        self._offset = math.inf
        self._last_board: int | None = None
        self._wraps = 0
        self._last_host = 0.0
        self._last_stamp = -math.inf
        self._last_time = 0.0

    def host_time(self, board_time_us: int, received: float) -> float:
        """The host time (s) at which the board read a sample stamped ``board_time_us``.

        ``received`` is the host time the sample arrived; the result is never later, and never
        earlier than the previous one.
        """
        if self._last_board is not None and board_time_us < self._last_board:
            self._wraps += 1
        self._last_board = board_time_us
        board = (self._wraps * BOARD_TIME_MODULO + board_time_us) * 1e-6
        if math.isfinite(self._offset):
            self._offset += DRIFT * max(0.0, received - self._last_host)
        self._last_host = received
        self._offset = min(self._offset, received - board)
        stamp = max(board + self._offset, self._last_stamp + CATCH_UP * (board - self._last_time))
        self._last_stamp, self._last_time = min(stamp, received), board
        return self._last_stamp


class HostClock:
    """The system clock time (ROS wall stamps) of a monotonic host time, never going back.

    The offset system − monotonic is constant but when the system clock is set (NTP slews both
    clocks alike). Read anew for every sample it would carry the time the reading thread was
    preempted between its two reads, enough on a loaded machine to stamp a sample before the
    one read 10 ms earlier. So it is read between two monotonic reads, and a reading changes it
    only when those were at most `TIGHT_READ_NS` apart and it differs by more than
    `CLOCK_STEP_NS`: the system clock was set, and the stamps follow it.

    Parameters
    ----------
    monotonic_ns, system_ns : callable
        The two clocks, ns (:func:`time.monotonic_ns` and :func:`time.time_ns`).
    """

    def __init__(
        self,
        monotonic_ns: Callable[[], int] = time.monotonic_ns,
        system_ns: Callable[[], int] = time.time_ns,
    ) -> None:
        self._monotonic_ns = monotonic_ns
        self._system_ns = system_ns
        self.offset_ns: int | None = None

    def system_ns(self, monotonic: float) -> int:
        """The system clock time, ns, of the monotonic host time ``monotonic`` (s)."""
        before = self._monotonic_ns()
        system = self._system_ns()
        after = self._monotonic_ns()
        offset = system - (before + after) // 2
        tight = after - before <= TIGHT_READ_NS
        if self.offset_ns is None or (tight and abs(offset - self.offset_ns) > CLOCK_STEP_NS):
            self.offset_ns = offset
        return round(monotonic * 1e9) + self.offset_ns


class RoundTrip:
    """Times from sending Openings to the first sample that applies them, s."""

    def __init__(self) -> None:
        self._sent: OrderedDict[int, float] = OrderedDict()
        self.last = math.nan
        self.count = 0
        self.total = 0.0
        self.largest = 0.0

    def sent(self, sequence: int, now: float) -> None:
        """Openings ``sequence`` left at ``now`` (s)."""
        self._sent[sequence % SEQUENCE_MODULO] = now
        while len(self._sent) > PENDING:
            self._sent.popitem(last=False)

    def applied(self, sequence: int, received: float) -> float | None:
        """A sample that applies ``sequence`` arrived at ``received``; its round trip, s.

        None when that sequence was answered already (or never sent).
        """
        sent = self._sent.pop(sequence, None)
        if sent is None:
            return None
        for older in [s for s, t in self._sent.items() if t <= sent]:  # superseded, never seen
            del self._sent[older]
        self.last = received - sent
        self.count += 1
        self.total += self.last
        self.largest = max(self.largest, self.last)
        return self.last

    @property
    def mean(self) -> float:
        """Mean round trip so far, s (nan before any)."""
        return self.total / self.count if self.count else math.nan
