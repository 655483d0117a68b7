"""The QoS profiles of the exodigit topics (docs/spec/ros.md, "QoS").

Every topic is reliable. Streams are volatile, as ROS streams are: a subscriber gets what is sent
after it matched, so ``ros2 topic echo --once chamber_pressure`` (which takes the publishers'
durability) prints the pressure the chambers hold now, not a replay of the last seconds. History
is kept for late readers only where it is a record or a latched state: the plant's
``applied_command`` (:data:`APPLIED_QOS`) and a node's ``~/ready`` (:data:`HANDED_OVER_QOS`).

The glove's own recorders (the runners' run record, the bag ``recorder``, the testing kit) lose
nothing of a stream because no plant steps before every node of the session has matched their
readers (the session protocol, :mod:`.handshake`), and they keep deep queues
(:data:`RECORD_QOS`) for when they fall behind. A subscriber with the default rclpy profile
(``depth=10``, volatile) matches every publisher.
"""

from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy

from .messages import APPLIED_COMMAND

WRITER_DEPTH = 1000
"""Samples each publisher keeps for matched readers that have not acknowledged them yet: 10 s at
100 Hz (a reader that misses one asks again within 50 ms, the project's Fast DDS profile)."""

RECORD_DEPTH = 10_000
"""Samples a recording subscription buffers while its process is behind: 100 s at 100 Hz."""

STREAM_QOS = QoSProfile(
    history=HistoryPolicy.KEEP_LAST,
    depth=WRITER_DEPTH,
    reliability=ReliabilityPolicy.RELIABLE,
    durability=DurabilityPolicy.VOLATILE,
)
"""Profile of every stream the glove's nodes publish (states, pressures, forces, estimates,
commands, markers, ``/diagnostics``, ``/clock``): reliable, keep-last :data:`WRITER_DEPTH`,
volatile. A matched reader that stalls gets every sample back as long as it is less than
:data:`WRITER_DEPTH` behind. The publisher never waits for anyone (keep-all would block it, then
fail, once a stalled reader is 5,000 samples behind: ``benchmarks/bench_transport.py``); a
runner in simulated time keeps the plant fewer steps ahead than that (``runner/horizon.py``)."""

APPLIED_QOS = QoSProfile(
    history=HistoryPolicy.KEEP_LAST,
    depth=WRITER_DEPTH,
    reliability=ReliabilityPolicy.RELIABLE,
    durability=DurabilityPolicy.TRANSIENT_LOCAL,
)
"""Profile of the plant's ``applied_command``, the record of what drove the glove: as
:data:`STREAM_QOS`, and transient-local, so that a reader that matched late still gets the
commands the plant took before (from the vent it starts with)."""

HANDED_OVER_QOS = QoSProfile(
    history=HistoryPolicy.KEEP_LAST,
    depth=1,
    reliability=ReliabilityPolicy.RELIABLE,
    durability=DurabilityPolicy.TRANSIENT_LOCAL,
)
"""Profile of a latched state (a node's ``~/ready``): keep-last 1, transient-local, so a reader
that matched after the state was said still gets it."""

READER_QOS = QoSProfile(
    history=HistoryPolicy.KEEP_LAST,
    depth=10,
    reliability=ReliabilityPolicy.RELIABLE,
    durability=DurabilityPolicy.VOLATILE,
)
"""Profile of every subscription of the glove nodes: reliable, keep-last 10, volatile."""

BACKLOG_QOS = QoSProfile(
    history=HistoryPolicy.KEEP_LAST,
    depth=WRITER_DEPTH,
    reliability=ReliabilityPolicy.RELIABLE,
    durability=DurabilityPolicy.VOLATILE,
)
"""Subscriptions of a node that must take every sample even while it is behind: the estimator
in simulated time, where a lockstep plant at real-time factor 0 steps on without waiting for it
(with :data:`READER_QOS`'s 10 it estimated 74-80 % of a test's states). Keeps as many as a
publisher (:data:`WRITER_DEPTH`); volatile, as :data:`READER_QOS`."""

RECORD_QOS = QoSProfile(
    history=HistoryPolicy.KEEP_LAST,
    depth=RECORD_DEPTH,
    reliability=ReliabilityPolicy.RELIABLE,
    durability=DurabilityPolicy.VOLATILE,
)
"""Subscriptions that must keep every message (the live summary's run record, the bag recorder,
the testing kit): keep-last :data:`RECORD_DEPTH`, so a recording process that falls behind a
plant running faster than real time buffers instead of dropping. Volatile, so every publisher
matches it, a user's controller with rclpy's default profile included."""

RECORD_APPLIED_QOS = QoSProfile(
    history=HistoryPolicy.KEEP_LAST,
    depth=RECORD_DEPTH,
    reliability=ReliabilityPolicy.RELIABLE,
    durability=DurabilityPolicy.TRANSIENT_LOCAL,
)
"""The recording subscription of ``applied_command``: :data:`RECORD_QOS`, transient-local to get
the plant's record (:data:`APPLIED_QOS`) whole."""


def record_profile(topic: str) -> QoSProfile:
    """The recording profile of ``topic`` (a name relative to a glove, or absolute).

    :data:`RECORD_APPLIED_QOS` for ``applied_command``, else :data:`RECORD_QOS`.
    """
    return RECORD_APPLIED_QOS if topic.rsplit('/', 1)[-1] == APPLIED_COMMAND else RECORD_QOS
