"""Subscription callbacks that take message info on every rclpy executor.

rclpy hands a callback the message info (DDS source timestamp, publication sequence number) when
the callback takes two arguments, ``(message, info)``. Its SingleThreadedExecutor calls it so;
the C++ EventsExecutor of rclpy 7.1 (Jazzy) passes the pair as one argument, ``((message,
info),)``, and a plain two-argument function fails there ("SystemError: null argument to internal
routine", measured with rclpy 7.1.6). :class:`WithInfo` declares the two arguments rclpy looks
for and accepts both calls, so a node whose callbacks need the info (the estimator pairs by send
time) spins on the EventsExecutor too, and keeps working when rclpy passes the two arguments.
"""

from __future__ import annotations

import inspect
from collections.abc import Callable
from typing import Any

InfoCallback = Callable[[Any, dict], None]

_TWO_ARGUMENTS = inspect.Signature(
    [
        inspect.Parameter('message', inspect.Parameter.POSITIONAL_ONLY),
        inspect.Parameter('info', inspect.Parameter.POSITIONAL_ONLY),
    ]
)


class WithInfo:
    """``callback(message, info)`` as a subscription callback for any rclpy executor.

    rclpy tells the kinds of callback apart by their signature; this object's is
    ``(message, info)``, so rclpy takes the info for it.
    """

    __signature__ = _TWO_ARGUMENTS

    def __init__(self, callback: InfoCallback) -> None:
        self.callback = callback

    def __call__(self, *taken: Any) -> None:
        """``(message, info)``, or the pair as one argument (rclpy 7.1's EventsExecutor)."""
        message, info = taken[0] if len(taken) == 1 else taken
        self.callback(message, info)
