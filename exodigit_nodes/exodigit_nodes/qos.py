"""The one QoS profile of every exodigit topic (docs/spec/ros.md, "QoS").

Reliable, keep-last 10, volatile: a subscriber with the default rclpy profile (``depth=10``)
matches it. ``markers`` and ``/diagnostics`` use the same profile at lower rates; ``/clock`` has
its own (:data:`CLOCK_QOS`).
"""

from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy

GLOVE_QOS = QoSProfile(
    history=HistoryPolicy.KEEP_LAST,
    depth=10,
    reliability=ReliabilityPolicy.RELIABLE,
    durability=DurabilityPolicy.VOLATILE,
)
"""Profile of every publisher and subscription of the glove nodes."""

CLOCK_QOS = QoSProfile(
    history=HistoryPolicy.KEEP_LAST,
    depth=1,
    reliability=ReliabilityPolicy.RELIABLE,
    durability=DurabilityPolicy.VOLATILE,
)
"""Profile of ``/clock`` (docs/spec/ros.md Part II): reliable, keep-last 1, which both rclpy's
best-effort time-source subscription and reliable subscribers match."""

RECORD_QOS = QoSProfile(
    history=HistoryPolicy.KEEP_LAST,
    depth=10_000,
    reliability=ReliabilityPolicy.RELIABLE,
    durability=DurabilityPolicy.VOLATILE,
)
"""Subscriptions that must keep every message (the live summary's run record, the bag recorder):
matches :data:`GLOVE_QOS` publishers, and buffers up to 100 s at 100 Hz when the plant runs faster
than real time in simulated time and the recording process falls behind."""
