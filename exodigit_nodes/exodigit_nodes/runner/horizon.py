"""Keeps a plant in simulated time at most a few hundred steps ahead of what a runner received.

Every glove publisher keeps its last 1,000 samples for readers that have not acknowledged them
(:data:`.qos.STREAM_QOS`), and a reader that misses one asks for it again within 50 ms (the
project's Fast DDS profile, :mod:`.dds`). A plant in simulated time at a real-time factor of 0
takes thousands of steps a second, faster than a Python process records them; without a hold,
a runner that falls 1,000 steps behind would lose the oldest. Measured on 2026-12-04 with
``benchmarks/bench_transport.py --case 1 --keep-all --topics 4 --rate 500 --period 4``: a
reader stopped for 1 s (500 samples behind on each topic) lost none of 20,000 from the
glove's publishers; stopped for 3 s (1,500 behind) it lost 2,014, and none from keep-all
publishers, which keep every unacknowledged sample (up to Fast DDS's 5,000, then they block).

So a runner in simulated time holds the plant with its ``run_until`` parameter
(:class:`.sim_time.SimulatedTime`): it keeps it at most `LEAD_STEPS` past the newest step that
every glove of the run has received whole (each of its streams: one held back holds the plant),
and raises it each time `RAISE_STEPS` more have arrived. A message in flight is then always
among what its publisher keeps, and nothing is lost. The testing kit holds the plant the same
way: what a user's controller answered, it reads from the plant's ``applied_command``, not from
the controller's publisher (which may keep only rclpy's usual 10).
"""

from __future__ import annotations

from rcl_interfaces.srv import GetParameters, SetParameters
from rclpy.node import Node

from ..nodes.messages import rate_request, set_double_request
from ..nodes.repeated_call import RepeatedCall

LEAD_STEPS = 400
"""Most steps the plant may take past the newest one received: fewer than the samples each
publisher keeps (:data:`.qos.WRITER_DEPTH`; one step in flight beyond them is still kept)."""
RAISE_STEPS = 100
"""Steps received between two raises of ``run_until``."""
RUN_UNTIL = 'run_until'


class Horizon:
    """The ``run_until`` of one plant, kept `LEAD_STEPS` ahead of the steps received.

    Parameters
    ----------
    node : rclpy.node.Node
        Calls the plant's parameter services (whoever spins it completes the calls).
    plant : str
        Fully qualified name of the plant whose simulated time it holds (in a hand, any finger's
        plant: they share one time).
    period : float, optional
        Simulated seconds per step; None: ask the plant its ``rate_hz``.
    """

    def __init__(self, node: Node, plant: str, *, period: float | None = None) -> None:
        self._get = None  # asks the rate only if it is not given
        if period is None:
            self._get = node.create_client(GetParameters, f'{plant}/get_parameters')
        self._set = node.create_client(SetParameters, f'{plant}/set_parameters')
        self._pending: RepeatedCall | None = None
        self.period = period
        """Simulated seconds per step, once known."""
        self.start(0.0)

    def start(self, end: float) -> None:
        """A new run that ends at simulated time ``end``, s (0 = open end): then :meth:`ready`.

        ``run_until`` never goes past ``end``.
        """
        self._end = end
        self._started = False
        self.limit = 0.0
        """The ``run_until`` last set, s."""

    def ready(self, received: float = 0.0) -> bool:
        """Set the first ``run_until`` past stamp ``received`` (s); True once the plant has it.

        Asks the plant's rate first if it was not given. Call it until True before the plant is
        resumed (it never blocks).
        """
        if self._started:
            return True
        if self._pending is None:
            if self.period is None and self._get.service_is_ready():
                self._pending = RepeatedCall(self._get, rate_request())
            elif self.period is not None and self._set.service_is_ready():
                self._raise(received)
            return False
        result = self._pending.answer()
        if result is None:
            return False
        self._pending = None
        if self.period is None:
            self.period = 1.0 / result.values[0].double_value
            self._raise(received)
            return False
        self._started = True
        return True

    def follow(self, received: float | None) -> None:
        """Raise ``run_until`` if the steps received (up to stamp ``received``, s) call for it."""
        if received is None or (self._pending is not None and self._pending.answer() is None):
            return
        self._pending = None
        if self._end and self.limit >= self._end:
            return
        if received + (LEAD_STEPS - RAISE_STEPS + 0.5) * self.period >= self.limit:
            self._raise(received)

    def release(self) -> RepeatedCall:
        """Set ``run_until`` back to 0 (no limit): the call, in flight.

        Sent on the client that raised it, so it reaches the plant after every raise (one
        reliable stream keeps its order; a raise held back for a heartbeat on another would
        land after it and hold the plant again). Then :meth:`start` a new run.
        """
        self._pending = None
        self._started = False
        self.limit = 0.0
        return RepeatedCall(self._set, set_double_request(RUN_UNTIL, 0.0))

    def _raise(self, received: float) -> None:
        limit = received + LEAD_STEPS * self.period
        self.limit = min(limit, self._end) if self._end else limit
        self._pending = RepeatedCall(self._set, set_double_request(RUN_UNTIL, self.limit))
