"""The QoS profiles of the exodigit topics (docs/spec/ros.md, "QoS").

Every topic is reliable and volatile, so a subscriber with the default rclpy profile
(``depth=10``) matches every publisher. Publishers keep the last 1,000 samples
(:data:`WRITER_QOS`), so a reader that keeps every message (:data:`RECORD_QOS`) loses none
when its process stalls for seconds. Subscriptions keep the last 10 (:data:`READER_QOS`): a
controller wants the latest state, not a backlog.
``markers``, ``/diagnostics`` and ``/clock`` use the same profiles (rclpy's best-effort time
source matches a reliable publisher too).
"""

from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy

WRITER_DEPTH = 1000
"""Samples each publisher keeps for readers that have not acknowledged them: 10 s at 100 Hz."""

WRITER_QOS = QoSProfile(
    history=HistoryPolicy.KEEP_LAST,
    depth=WRITER_DEPTH,
    reliability=ReliabilityPolicy.RELIABLE,
    durability=DurabilityPolicy.VOLATILE,
)
"""Profile of every publisher of the glove nodes: reliable, keep-last :data:`WRITER_DEPTH`,
volatile. A reader that stalls gets every sample back as long as it is less than
:data:`WRITER_DEPTH` behind (the project's profile, :mod:`.dds`, repairs its gap within 50 ms);
the publisher never waits for anyone (keep-all would block it, then fail, once a stalled reader
is 5,000 samples behind: ``benchmarks/bench_transport.py``)."""

READER_QOS = QoSProfile(
    history=HistoryPolicy.KEEP_LAST,
    depth=10,
    reliability=ReliabilityPolicy.RELIABLE,
    durability=DurabilityPolicy.VOLATILE,
)
"""Profile of every subscription of the glove nodes: reliable, keep-last 10, volatile."""

RECORD_QOS = QoSProfile(
    history=HistoryPolicy.KEEP_LAST,
    depth=10_000,
    reliability=ReliabilityPolicy.RELIABLE,
    durability=DurabilityPolicy.VOLATILE,
)
"""Subscriptions that must keep every message (the live summary's run record, the bag recorder):
with :data:`WRITER_QOS` publishers they get every sample, and they buffer up to 100 s at 100 Hz
when the plant runs faster than real time in simulated time and the recording process falls
behind."""
