"""The QoS profiles of the exodigit topics; docs/spec/ros.md, "QoS", has why each is so."""

from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy

from .messages import APPLIED_COMMAND

WRITER_DEPTH = 1000
"""Samples each publisher keeps for matched readers that have not acknowledged them yet: 10 s at
100 Hz."""
RECORD_DEPTH = 10_000
"""Samples a recording subscription buffers while its process is behind: 100 s at 100 Hz."""


def _reliable(depth: int, durability: DurabilityPolicy) -> QoSProfile:
    return QoSProfile(
        history=HistoryPolicy.KEEP_LAST,
        depth=depth,
        reliability=ReliabilityPolicy.RELIABLE,
        durability=durability,
    )


STREAM_QOS = _reliable(WRITER_DEPTH, DurabilityPolicy.VOLATILE)
"""Every stream the glove's nodes publish (states, pressures, forces, estimates, commands,
markers, ``/diagnostics``, ``/clock``). Keep-last, so that the publisher never blocks on a
stalled reader (keep-all blocks, then fails, 5,000 samples behind:
``benchmarks/bench_transport.py``); the runners keep a plant fewer steps ahead than that.
Also the estimator's inputs in simulated time: a lockstep plant does not wait for it, and with
:data:`READER_QOS` it estimated 74-80 % of a test's states."""
APPLIED_QOS = _reliable(WRITER_DEPTH, DurabilityPolicy.TRANSIENT_LOCAL)
"""The plant's ``applied_command``, the record of what drove the glove, from the vent it starts
with: a reader that matched late still gets it whole."""
HANDED_OVER_QOS = _reliable(1, DurabilityPolicy.TRANSIENT_LOCAL)
"""A latched state (a node's ``~/ready``)."""
READER_QOS = _reliable(10, DurabilityPolicy.VOLATILE)
"""Every subscription of the glove nodes but the estimator's in simulated time."""
RECORD_QOS = _reliable(RECORD_DEPTH, DurabilityPolicy.VOLATILE)
"""Subscriptions that must keep every message (the runners' run record, the bag recorder, the
testing kit). Volatile, so that every publisher matches it, rclpy's default profile included."""
RECORD_APPLIED_QOS = _reliable(RECORD_DEPTH, DurabilityPolicy.TRANSIENT_LOCAL)
"""The recording subscription of ``applied_command``, to get :data:`APPLIED_QOS`'s record."""


def record_profile(topic: str) -> QoSProfile:
    """The recording profile of ``topic`` (relative to a glove, or absolute)."""
    return RECORD_APPLIED_QOS if topic.rsplit('/', 1)[-1] == APPLIED_COMMAND else RECORD_QOS
