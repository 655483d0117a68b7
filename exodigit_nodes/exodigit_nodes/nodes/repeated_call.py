"""A service request that may be repeated, sent again until answered (:class:`RepeatedCall`)."""

from __future__ import annotations

import time

RESEND = 1.0
"""Wall seconds without an answer before a request is sent again. rmw_fastrtps drops a service's
answer when the server has not yet matched the client's reader (it waits 100 ms), which happens
on a loaded machine. Only a request that may be asked twice is to be repeated (a parameter
question, ``run_until``), never one that does something each time (the plant's ``step``)."""


class RepeatedCall:
    """A request that may be repeated, in flight: sent again every `RESEND` s until answered."""

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
