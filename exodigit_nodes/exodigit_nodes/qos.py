"""The one QoS profile of every exodigit topic (INTERFACES.md, "QoS").

Reliable, keep-last 10, volatile: a subscriber with the default rclpy profile (``depth=10``)
matches it. ``markers`` and ``/diagnostics`` use the same profile at lower rates.
"""

from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy

GLOVE_QOS = QoSProfile(
    history=HistoryPolicy.KEEP_LAST,
    depth=10,
    reliability=ReliabilityPolicy.RELIABLE,
    durability=DurabilityPolicy.VOLATILE,
)
"""Profile of every publisher and subscription of the glove nodes."""
