"""Holds a simulated plant with its ``run_until``: the one rule of the runners and the kit.

At most `LEAD_STEPS` past the newest step every glove has received whole (fewer than the
:data:`.qos.WRITER_DEPTH` samples a publisher keeps for a reader that has not acknowledged
them), raised each time `RAISE_STEPS` more have arrived, and never past the end of the run
(docs/spec/ros.md, "The session protocol", guarantee 6).
"""

from __future__ import annotations

from rcl_interfaces.srv import GetParameters, SetParameters
from rclpy.node import Node

from ..nodes.messages import rate_request, set_double_request
from ..nodes.repeated_call import RepeatedCall

LEAD_STEPS = 400
"""Most steps the plant may take past the newest one received (fewer than a publisher keeps)."""
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
        self._get = None
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
        """Set ``run_until`` back to 0 (no limit): the call, in flight; then :meth:`start`.

        Sent on the client that raised it: one reliable stream keeps it after every raise.
        """
        self._pending = None
        self._started = False
        self.limit = 0.0
        return RepeatedCall(self._set, set_double_request(RUN_UNTIL, 0.0))

    def _raise(self, received: float) -> None:
        limit = received + LEAD_STEPS * self.period
        self.limit = min(limit, self._end) if self._end else limit
        self._pending = RepeatedCall(self._set, set_double_request(RUN_UNTIL, self.limit))
