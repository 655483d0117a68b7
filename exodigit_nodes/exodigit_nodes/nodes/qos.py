"""The QoS profiles of the exodigit topics (docs/spec/ros.md, "QoS").

Every topic is reliable. Publishers keep the last 1,000 samples (:data:`WRITER_QOS`), and keep
them for readers that match late (durability transient-local): a recorder whose reader matched
a plant a few hundred steps after the plant started still gets those steps
(:data:`RECORD_QOS`). Subscriptions of the nodes keep the last 10 and ask for nothing sent
before they matched (:data:`READER_QOS`): a controller wants the latest state, not a backlog.
A subscriber with the default rclpy profile (``depth=10``, volatile) matches every publisher.
``markers``, ``/diagnostics`` and ``/clock`` use the same profiles (rclpy's best-effort time
source matches a reliable publisher too).
"""

from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy

from .messages import (
    CLOCK,
    DIAGNOSTICS,
    JOINT_TARGETS,
    PATIENT_EFFORT,
    PRESSURE_COMMAND,
    VALVE_COMMAND,
)

WRITER_DEPTH = 1000
"""Samples each publisher keeps, for readers that have not acknowledged them and for readers
that match late: 10 s at 100 Hz."""

RECORD_DEPTH = 10_000
"""Samples a recording subscription buffers while its process is behind: 100 s at 100 Hz."""

WRITER_QOS = QoSProfile(
    history=HistoryPolicy.KEEP_LAST,
    depth=WRITER_DEPTH,
    reliability=ReliabilityPolicy.RELIABLE,
    durability=DurabilityPolicy.TRANSIENT_LOCAL,
)
"""Profile of every publisher of the glove nodes: reliable, keep-last :data:`WRITER_DEPTH`,
transient-local. A reader that stalls gets every sample back as long as it is less than
:data:`WRITER_DEPTH` behind (the project's profile, :mod:`.dds`, repairs its gap within 50 ms);
a transient-local reader that matches late gets the last :data:`WRITER_DEPTH` samples sent
before (discovery between two processes took up to 3 s on a loaded machine, while a plant in
simulated time stepped on: a hand's bag once held no step of a plant). The publisher never
waits for anyone (keep-all would block it, then fail, once a stalled reader is 5,000 samples
behind: ``benchmarks/bench_transport.py``). Volatile readers (rclpy's default) match it too and
get only what is sent after they matched."""

HANDED_OVER_QOS = QoSProfile(
    history=HistoryPolicy.KEEP_LAST,
    depth=1,
    reliability=ReliabilityPolicy.RELIABLE,
    durability=DurabilityPolicy.TRANSIENT_LOCAL,
)
"""Profile of a publisher that sends its next sample only once every reader has acknowledged
the last (the testing kit's ``joint_targets``, one target a step): keep-last 1 loses nothing
then, and Fast DDS sends a heartbeat with every sample of a full history, which the reader
answers at once (the kit's profile), so the acknowledgement comes back in one round trip. With
the usual 1,000 it waited for the periodic heartbeat: 1.2 ms a step against 0.03 ms (500 lockstep
steps here). Transient-local as :data:`WRITER_QOS`, so every reader profile matches it."""

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
    durability=DurabilityPolicy.TRANSIENT_LOCAL,
)
"""Subscriptions that must keep every message of the glove's own nodes (the live summary's run
record, the bag recorder, the testing kit): transient-local, so a reader that matched after the
plant's first steps still gets them from the publisher's history, and keep-last
:data:`RECORD_DEPTH`, so a recording process that falls behind a plant running faster than real
time buffers instead of dropping. Only publishers that are transient-local match it (every
publisher of :data:`WRITER_QOS`); for topics that other nodes publish too, see
:data:`RECORD_ANY_QOS`."""

RECORD_ANY_QOS = QoSProfile(
    history=HistoryPolicy.KEEP_LAST,
    depth=RECORD_DEPTH,
    reliability=ReliabilityPolicy.RELIABLE,
    durability=DurabilityPolicy.VOLATILE,
)
"""Recording subscriptions of topics that any node may publish with rclpy's default (volatile)
profile: a user's controller on ``pressure_command``, ``valve_command``, ``patient_effort`` and
``joint_targets``, every node on ``/diagnostics``, another simulator on ``/clock``. Volatile, so
that such a publisher matches; what it sent before the match is not recorded."""

OPEN_TOPICS = frozenset(
    {PRESSURE_COMMAND, VALVE_COMMAND, PATIENT_EFFORT, JOINT_TARGETS, DIAGNOSTICS, CLOCK}
)
"""Topics that nodes other than the glove's own publish (docs/spec/ros.md, "QoS"): recorded with
:data:`RECORD_ANY_QOS`. Every other glove topic has only the plant or the estimator as its
publisher."""


def record_profile(topic: str) -> QoSProfile:
    """The recording profile of ``topic`` (a name relative to a glove, or absolute).

    :data:`RECORD_ANY_QOS` for :data:`OPEN_TOPICS`, else :data:`RECORD_QOS`.
    """
    name = topic if topic in OPEN_TOPICS else topic.rsplit('/', 1)[-1]
    return RECORD_ANY_QOS if name in OPEN_TOPICS else RECORD_QOS
