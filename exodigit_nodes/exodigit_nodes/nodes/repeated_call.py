"""A service request sent again until answered (:class:`RepeatedCall`)."""

from __future__ import annotations

import time

RESEND = 1.0
"""Wall seconds without an answer before a request is sent again: rmw_fastrtps drops an answer
when the server has not matched the client's reader yet (docs/spec/ros.md, "The session
protocol"). Repeat only a request that may be asked twice (a parameter question,
``run_until``), never one that acts each time (the plant's ``step``)."""


class RepeatedCall:
    """A request in flight, sent again every :data:`RESEND` s until answered."""

    def __init__(self, client, request) -> None:
        self._client, self._request = client, request
        self._send()

    def _send(self) -> None:
        self._future = self._client.call_async(self._request)
        self._sent = time.monotonic()

    def answer(self):
        """The response, or None while there is none (sending again when overdue)."""
        if self._future.done():
            return self._future.result()
        if time.monotonic() - self._sent > RESEND:
            self._client.remove_pending_request(self._future)
            self._send()
        return None
