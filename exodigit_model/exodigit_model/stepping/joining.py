"""Pairing the samples of a glove's streams by time: one rule for live topics and for bags.

The estimator pairs angles with pressures, the live summary joins a plant step's pressures,
angles and forces, and ``exodigit plot`` pairs the angles and pressures of a bag. All three use
this module (numpy only, no ROS): samples are paired by time, never by their arrival order or
their sequence numbers (which restart with every publisher: a replayed bag, a restarted plant).

The time of a sample
--------------------
Two samples are compared on one clock: the time each was *sent*, whatever the stream.

* Live, it is the DDS source timestamp of the message (``source_timestamp`` in rclpy's message
  info): the sending host's system clock at the write, for a JointState as for a
  Float64MultiArray, which has no header.
* In a bag, it is the time the bag logged the message (the recorder's clock when it arrived;
  under ``use_sim_time`` the simulated time the recorder had heard, so a bag of a simulated
  session pairs only as well as its recorder kept up with ``/clock``).

A JointState's header stamp is *not* what pairs it. In simulated time the plant stamps a step
with its simulated time t_k (docs/spec/ros.md Part II) while every source timestamp is wall time,
and a replayed bag carries the recording's stamps while the player sends them now: pairing a
header stamp with a header-less message's time would compare two clocks, not two samples. The
header stamp stays the sample's *stamp*: the time on the glove's clock that the estimator checks
for age and the summary reports as the step's time.

The rule
--------
One stream *leads*: a sample of it opens a group, and each sample of another stream belongs to
the latest lead sample sent at or before it. A lead sample at t pairs with, for each other
stream, the first sample at or after t, provided that sample comes before the next lead sample
and at most ``tolerance`` after t; otherwise the lead sample pairs with nothing (it is dropped and
counted, as is every sample left over). For the plant the lead is ``chamber_pressure``: each step
publishes it first, then ``joint_states``, ``contact_forces`` and ``segment_lengths``
(``Plant.publish_state``), so the rule pairs the messages of one step however long the plant is
preempted between two of them. Nearest times would not: on an overloaded machine (three gloves on
two busy cores) a step's angles were sent up to 27 ms after its pressure while a late plant caught
up with steps 0.5 ms apart, and the nearest angles of a pressure were then its neighbour's. With
streams at different rates (pressure at 50 Hz, angles at 100 Hz) each pressure pairs with the
first angles after it and the angles in between pair with nothing.

A stream whose sample is refused (malformed, stale) still offers it, with the value None: the
sample keeps its place, so its lead is not paired with the next step's sample instead.

:class:`Joiner` applies the rule online, message by message; :func:`join_indices` to recorded
arrays. Both give the same pairs for the same samples: online with ``confirm`` in any arrival
order, without it when every sample arrives after the lead samples sent before it.
"""

from __future__ import annotations

import math
from collections import deque
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

STEP_TOLERANCE = 0.1
"""Default tolerance: longest time from a lead sample to a sample still paired with it, s (the
plant sends a step's messages back to back, 27 ms apart at worst on an overloaded machine; a
glove's sensors run at tens of hertz)."""
STALL_TOLERANCE = 10.0
"""Tolerance for one publisher's steps (the plant's, a board's), joined once the next step's
lead sample is known: the group already ends there, so this bounds only the last step, and a
plant stalled between two messages of a step (a garbage collection, a busy machine) keeps the
step. The estimator, which answers at once, keeps `STEP_TOLERANCE`."""
MAX_WAITING = 256
"""Samples kept per stream while their group is incomplete (a silent stream holds no more)."""


@dataclass(frozen=True)
class Joined:
    """One group: a lead sample and the sample of each other stream paired with it.

    Attributes
    ----------
    time : float
        When the lead sample was sent, s (the joiner's clock).
    values : dict
        Stream name -> the value its sample was offered with, for every stream.
    """

    time: float
    values: dict[str, Any]


class Joiner:
    """Pairs samples of several streams by the time they were sent, online (module docstring).

    Each stream must be offered in the order it was sent (DDS delivers one publisher's messages
    in order; a bag is read in log order). A sample older than the latest of its stream starts a
    new time line (a bag replayed again, a clock set back): everything waiting is dropped.

    Parameters
    ----------
    streams : sequence of str
        Stream names; the first leads.
    tolerance : float
        Longest time from a lead sample to a sample paired with it, s.
    confirm : bool
        Emit a group only once the next lead sample has arrived, or at :meth:`flush` (one lead
        sample later, and then exactly the groups of :func:`join_indices` in any arrival order).
        False: emit a group as soon as it is complete, what a node in lockstep needs. Then a
        sample whose lead sample has not arrived yet can be taken for an earlier lead sample
        whose own partner was lost; its lead sample then pairs with nothing, so the error does
        not carry over to the next groups. Offering the lead stream first when both have
        samples waiting (as they were sent) avoids it.

    Raises
    ------
    ValueError
        Fewer than two streams, a name twice, or a tolerance that is not a positive number.
    """

    def __init__(
        self, streams: Sequence[str], *, tolerance: float = STEP_TOLERANCE, confirm: bool = False
    ) -> None:
        names = tuple(streams)
        if len(names) < 2 or len(set(names)) != len(names):
            raise ValueError(f'streams {names!r}: need two or more distinct names')
        if not (math.isfinite(tolerance) and tolerance > 0.0):
            raise ValueError(f'tolerance {tolerance!r}: must be a positive number of seconds')
        self.lead, *self.partners = names
        self.tolerance = tolerance
        self.confirm = confirm
        self.unpaired = 0
        """Samples dropped without a group so far."""
        self._waiting: dict[str, deque[tuple[float, Any]]] = {name: deque() for name in names}
        self._latest = dict.fromkeys(names, -math.inf)
        self._taken = dict.fromkeys(self.partners, -math.inf)  # latest sample put in a group

    def add(self, stream: str, time: float, value: Any) -> list[Joined]:
        """Offer a sample of ``stream`` sent at ``time`` (s); the groups it completes, in order.

        Raises
        ------
        ValueError
            An unknown stream or a time that is not finite.
        """
        if stream not in self._waiting:
            raise ValueError(f'unknown stream {stream!r}; expected one of {list(self._waiting)}')
        if not math.isfinite(time):
            raise ValueError(f'{stream} sample time {time!r}: must be finite')
        if time < self._latest[stream]:
            self.clear()
        self._latest[stream] = time
        queue = self._waiting[stream]
        queue.append((time, value))
        if len(queue) > MAX_WAITING:
            queue.popleft()
            self.unpaired += 1
        return self._join(final=False)

    def flush(self) -> list[Joined]:
        """The groups still waiting for the next lead sample, when no more samples will come."""
        return self._join(final=True)

    def clear(self) -> None:
        """Drop every waiting sample (counted as unpaired) and start a new time line."""
        self.unpaired += sum(len(queue) for queue in self._waiting.values())
        for queue in self._waiting.values():
            queue.clear()
        self._latest = dict.fromkeys(self._latest, -math.inf)
        self._taken = dict.fromkeys(self._taken, -math.inf)

    def _join(self, *, final: bool) -> list[Joined]:
        joined = []
        leads = self._waiting[self.lead]
        while leads:
            time, value = leads[0]
            following = leads[1][0] if len(leads) > 1 else math.inf
            values, complete, dead = {self.lead: value}, True, False
            for stream in self.partners:
                queue = self._waiting[stream]
                while queue and queue[0][0] < time:  # an earlier lead's, or nobody's
                    queue.popleft()
                    self.unpaired += 1
                if self._taken[stream] >= time:
                    dead = True  # its sample went to an earlier lead (which lost its own)
                    break
                if not queue:
                    complete = False  # its sample may still come
                elif queue[0][0] >= following or queue[0][0] - time > self.tolerance:
                    dead = True  # the first sample after this lead is not its own
                    break
                else:
                    values[stream] = queue[0][1]
            if dead:
                leads.popleft()
                self.unpaired += 1
                continue
            if not complete or (self.confirm and following == math.inf and not final):
                break
            leads.popleft()
            for stream in self.partners:
                self._taken[stream] = self._waiting[stream].popleft()[0]
            joined.append(Joined(time, values))
        return joined


def join_indices(
    lead_times: ArrayLike, times: ArrayLike, *, tolerance: float = STEP_TOLERANCE
) -> NDArray[np.intp]:
    """For each lead sample, the index of the sample of another stream paired with it, or −1.

    The rule of the module docstring on recorded samples: ``times[j]`` pairs with lead sample i
    when it is the first at or after ``lead_times[i]``, comes before ``lead_times[i + 1]`` and at
    most ``tolerance`` after ``lead_times[i]``.

    Parameters
    ----------
    lead_times, times : array_like, shape (N,) and (M,)
        Times the samples were sent (or logged), s, each in non-decreasing order.
    tolerance : float
        Longest time from a lead sample to its partner, s.

    Raises
    ------
    ValueError
        Times that are not one-dimensional, finite and non-decreasing.
    """
    lead = _ordered('lead_times', lead_times)
    other = _ordered('times', times)
    first = np.searchsorted(other, lead, side='left')
    found = first < other.size
    partner = other[np.minimum(first, max(other.size - 1, 0))] if other.size else lead
    following = np.append(lead[1:], np.inf)
    paired = found & (partner < following) & (partner - lead <= tolerance)
    return np.where(paired, first, -1).astype(np.intp)


def _ordered(name: str, values: ArrayLike) -> NDArray[np.float64]:
    array = np.asarray(values, dtype=float)
    if array.ndim != 1 or not np.isfinite(array).all() or np.any(np.diff(array) < 0.0):
        raise ValueError(f'{name}: need finite times in non-decreasing order, one per sample')
    return array
