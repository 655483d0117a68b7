"""Keeps a plant in simulated time at most a few steps ahead of what a runner has received.

Every glove topic keeps the last 10 messages of each publisher (INTERFACES.md, "QoS"). A reader
that misses a message (Fast DDS dropped it on the way, which a loaded machine makes more likely)
holds back the ones after it until the publisher's next heartbeat, up to 3 s later, and gets it
again only if it is still among those 10. A plant in simulated time at a real-time factor of 0
takes hundreds of steps in that time, so the runner's record lost runs of 9 to 49 steps (one
lockstep hand run in four on this 2-core machine beside two busy processes, one in six idle).

So a runner in simulated time holds the plant with its ``run_until`` parameter
(:class:`.sim_time.SimulatedTime`): it keeps it at most `LEAD_STEPS` past the newest step that
every glove of the run has received, and raises it each time `RAISE_STEPS` more have arrived.
A message in flight is then always among the last 10 of its publisher; a reader that waits for a
heartbeat holds the plant for as long, and nothing is lost.
"""

from __future__ import annotations

from rcl_interfaces.srv import GetParameters, SetParameters
from rclpy.node import Node

from .messages import set_double_request

LEAD_STEPS = 8
"""Most steps the plant may take past the newest one received: fewer than the 10 messages each
publisher keeps (one step in flight beyond them is still among those 10)."""
RAISE_STEPS = 4
"""Steps received between two raises of ``run_until``."""
RUN_UNTIL = 'run_until'


class Horizon:
    """The ``run_until`` of one plant, kept `LEAD_STEPS` ahead of the steps received.

    Parameters
    ----------
    node : rclpy.node.Node
        Calls the plant's parameter services.
    plant : str
        Fully qualified name of the plant whose simulated time it holds (in a hand, any finger's
        plant: they share one time).
    duration : float
        Simulated seconds of the run (0 until stopped): ``run_until`` never goes past it.
    """

    def __init__(self, node: Node, plant: str, duration: float) -> None:
        self._get = node.create_client(GetParameters, f'{plant}/get_parameters')
        self._set = node.create_client(SetParameters, f'{plant}/set_parameters')
        self._duration = duration
        self._pending = None
        self._started = False
        self.period: float | None = None
        """Simulated seconds per step (the plant's ``rate_hz``), once it has answered."""
        self.limit = 0.0
        """The ``run_until`` last set, s."""

    def ready(self) -> bool:
        """Ask the plant's rate, then set the first ``run_until``; True once both are done.

        Call it until True before the plant is resumed (it never blocks).
        """
        if self._started:
            return True
        if self._pending is None:
            if self._get.service_is_ready():
                self._pending = self._get.call_async(GetParameters.Request(names=['rate_hz']))
            return False
        if not self._pending.done():
            return False
        result, self._pending = self._pending.result(), None
        if self.period is None:
            self.period = 1.0 / result.values[0].double_value
            self._raise(0.0)
            return False
        self._started = True
        return True

    def follow(self, received: float | None) -> None:
        """Raise ``run_until`` if the steps received (up to stamp ``received``, s) call for it."""
        if received is None or (self._pending is not None and not self._pending.done()):
            return
        self._pending = None
        if self._duration and self.limit >= self._duration:
            return
        if received + (LEAD_STEPS - RAISE_STEPS + 0.5) * self.period >= self.limit:
            self._raise(received)

    def _raise(self, received: float) -> None:
        limit = received + LEAD_STEPS * self.period
        self.limit = min(limit, self._duration) if self._duration else limit
        self._pending = self._set.call_async(set_double_request(RUN_UNTIL, self.limit))
