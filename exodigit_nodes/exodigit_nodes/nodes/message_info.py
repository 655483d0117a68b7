"""Subscription callbacks that take message info on every rclpy executor (:class:`WithInfo`)."""

from __future__ import annotations

import inspect
from collections.abc import Callable
from typing import Any


class WithInfo:
    """``callback(message, info)`` as a subscription callback for any rclpy executor.

    rclpy passes the message info (source timestamp, publication sequence number) to a callback
    whose signature has two arguments. The SingleThreadedExecutor calls it so; the EventsExecutor
    of rclpy 7.1 passes the pair as one argument, where a plain two-argument function fails
    ("SystemError: null argument to internal routine"). This object has the two-argument
    signature and takes both calls.
    """

    __signature__ = inspect.Signature(
        [
            inspect.Parameter('message', inspect.Parameter.POSITIONAL_ONLY),
            inspect.Parameter('info', inspect.Parameter.POSITIONAL_ONLY),
        ]
    )

    def __init__(self, callback: Callable[[Any, dict], None]) -> None:
        self.callback = callback

    def __call__(self, *taken: Any) -> None:
        """``(message, info)``, or the pair as one argument (rclpy 7.1's EventsExecutor)."""
        message, info = taken[0] if len(taken) == 1 else taken
        self.callback(message, info)
