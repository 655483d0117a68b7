"""A glove node class run in this process, its callbacks driven directly: no DDS traffic.

`InProcessNode` constructs a node class in the test probe's rclpy context (node-local
``--ros-args`` parameter overrides; no second DDS participant in the test process, see
:meth:`ros_harness.RosProbe.local_node`), replaces each publisher's ``publish`` with a
recorder, and hands out the node's subscription and timer callbacks. A test feeds the
subscription callbacks messages that went through an ``rclpy.serialization`` round trip (what
the wire would deliver) and fires the timers by hand; the recorded outputs are then checked.
"""

from __future__ import annotations

import inspect
import math
import time
from collections import defaultdict
from collections.abc import Iterator, Sequence

from rclpy.serialization import deserialize_message, serialize_message

#: Namespace of in-process nodes, so no other test's publisher ever matches their subscriptions.
NAMESPACE = '/in_process_test'


def wire_copy(message):
    """``message`` after serialization and deserialization, as a subscriber receives it."""
    return deserialize_message(serialize_message(message), type(message))


def numbers(message) -> Iterator[float]:
    """Every float a published message carries (data, positions, poses, scales, points...)."""
    if isinstance(message, float):
        yield message
        return
    if isinstance(message, (str, bytes, int, bool)) or message is None:
        return
    if isinstance(message, Sequence) or hasattr(message, 'tolist'):
        for item in message:
            yield from numbers(item)
        return
    for field in message.get_fields_and_field_types():
        yield from numbers(getattr(message, field))


class InProcessNode:
    """Node class ``node_class`` built in-process with parameter ``overrides``.

    Parameters
    ----------
    node_class : type
        A glove node class (constructed with no arguments).
    overrides : dict
        Parameter name -> value as a ``-p name:=value`` string.
    probe : RosProbe
        The test probe, whose context the node joins (in namespace `NAMESPACE`; nothing spins
        it but the test).
    """

    def __init__(self, node_class: type, overrides: dict[str, str], probe) -> None:
        args = ['--ros-args', '-r', f'__ns:={NAMESPACE}']
        args += [f for k, v in overrides.items() for f in ('-p', f'{k}:={v}')]
        self.node = node_class(context=probe.context, cli_args=args)
        self.published: dict[str, list] = defaultdict(list)
        self.sequence: dict[str, int] = {}
        for publisher in self.node.publishers:
            topic = publisher.topic_name.removeprefix(NAMESPACE + '/')
            publisher.publish = self._recorder(topic)

    def _recorder(self, topic: str):
        def record(message) -> None:
            self.published[topic].append(wire_copy(message))

        return record

    def subscriptions(self) -> dict[str, tuple[type, object]]:
        """Relative topic name -> (message type, callback) of every subscription."""
        return {
            sub.topic_name.rsplit('/', 1)[-1]: (sub.msg_type, sub.callback)
            for sub in self.node.subscriptions
        }

    def deliver(self, topic: str, message) -> None:
        """Hand ``message`` (after a wire round trip) to the subscription of ``topic``.

        A callback taking message info gets what rclpy would give: one publisher per topic,
        numbering its messages 1, 2, ... (``publication_sequence_number``).
        """
        _, callback = self.subscriptions()[topic]
        if len(inspect.signature(callback).parameters) == 1:
            callback(wire_copy(message))
            return
        self.sequence[topic] = self.sequence.get(topic, 0) + 1
        now = time.time_ns()
        info = {
            'source_timestamp': now,
            'received_timestamp': now,
            'publication_sequence_number': self.sequence[topic],
            'reception_sequence_number': self.sequence[topic],
        }
        callback(wire_copy(message), info)

    def fire_timers(self) -> None:
        """Run every timer callback of the node once (a cycle of the node's loops)."""
        for timer in list(self.node.timers):
            timer.callback()

    def take(self) -> dict[str, list]:
        """Messages published since the last call, by topic (the record is cleared).

        Topics of the node's namespace are keyed by their relative name (``joint_states``),
        others by their absolute name (``/diagnostics``).
        """
        taken = dict(self.published)
        self.published.clear()
        return taken

    def close(self) -> None:
        """Destroy the node (the probe's context stays up)."""
        self.node.destroy_node()


def non_finite(published: dict[str, list]) -> list[str]:
    """Lines naming every non-finite number in the published messages."""
    return [
        f'{topic}: {value!r}'
        for topic, messages in published.items()
        for message in messages
        for value in numbers(message)
        if not math.isfinite(value)
    ]
