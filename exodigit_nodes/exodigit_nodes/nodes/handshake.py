"""The session protocol: who must be present, the one handshake, and ``~/ready``.

The glove's streams are volatile (:mod:`.qos`): a reader gets what a publisher sends after the
publisher has matched it. Discovery is per pair of processes and took up to 3 s on a loaded
machine, so a reader that one process already lists may be unknown to another for a while. So
no plant of a session steps until every node that publishes has matched every reader that must
get all of it (the run record, the bag, the estimator, the testing kit): docs/spec/ros.md, "The
session protocol", has the whole sequence and the test of each guarantee.

How a reader knows: :class:`Handshake`. It makes its readers first, then asks each node it
listens to a harmless question (``get_parameters`` of no name: every ROS node serves it) on a
client made after them, again until answered (:class:`.repeated_call.RepeatedCall`). Fast DDS
announces a participant's readers in the order they were made, on one reliable stream, and a
server sends its answer only once it has matched the client's reader of answers, the last one
made: a node that has answered has matched every reader made before, and its publishers send
them everything from then on. (One ``GetParameters`` client per node, not rclpy's
``AsyncParameterClient``, which makes six.)

How the others know: a node that must hear a whole session (the recorder, the estimator)
publishes ``True`` on ``~/ready`` (std_msgs/Bool, latched: :data:`.qos.HANDED_OVER_QOS`) once
every node it listens to has answered (:class:`Ready`), and logs it; after :data:`NOTICE`
seconds without, it logs, once, whom it still waits for. :class:`ReadyWatch` is the other side:
the runners and the testing kit hold the plant (paused) until each listener has said it, and
until each node has answered their own handshake.
"""

from __future__ import annotations

import functools
import time
from collections.abc import Iterable

from rcl_interfaces.srv import GetParameters
from rclpy.clock import Clock, ClockType
from rclpy.node import Node
from std_msgs.msg import Bool

from ..logic.pacing import known_node
from .qos import HANDED_OVER_QOS
from .repeated_call import RepeatedCall

READY = '~/ready'
"""The topic, private to the node (``/hand/recorder/ready``)."""
POLL = 0.05
"""How often a :class:`Ready` node looks for the answers until it is ready, s."""
NOTICE = 3.0
"""Wall seconds without every answer before a :class:`Ready` node says, once, whom it waits for."""


def ready_topic(node: str) -> str:
    """The ``~/ready`` topic of the node named ``node`` (absolute, or relative to the reader's)."""
    return f'{node}/{READY.removeprefix("~/")}'


def glove_nodes(namespaces: Iterable[str], names: Iterable[str]) -> list[str]:
    """The nodes ``names`` of every glove of ``namespaces``: ``<namespace>/<name>``.

    A namespace absolute (``/hand/index``), relative to the asking node's (``index``), or ''
    for the asking node's own; the names come from the node table (:mod:`.catalog`) and the
    run's options (which nodes run).
    """
    names = list(names)
    return [
        f'{namespace.rstrip("/")}/{name}' if namespace.strip('/') else name
        for namespace in namespaces
        for name in names
    ]


def matched_every_listed(node: Node, publisher, least: int = 0) -> bool:
    """Whether ``publisher`` of ``node`` has matched every subscriber the graph lists (>= least).

    The graph lists a subscriber as soon as ``node``'s participant has discovered it; the match
    can follow a moment later, and a volatile publisher sends only to the readers it matched.
    """
    listed = node.count_subscribers(publisher.topic_name)
    return publisher.get_subscription_count() >= max(listed, least)


def controllers_matched(node: Node, commands, states) -> list[str]:
    """Nodes that publish on ``commands`` and read ``states``, both matched with ``node``.

    ``commands`` is a subscription of ``node``, ``states`` one of its publishers; nobody until
    the subscription has matched every publisher the graph lists. Fully qualified names,
    sorted; a node whose name the graph does not know yet is left out.
    """
    if node.count_publishers(commands.topic_name) > commands.get_publisher_count():
        return []
    publishers = node.get_publishers_info_by_topic(commands.topic_name)
    readers = node.get_subscriptions_info_by_topic(states.topic_name)
    listening = {(info.node_namespace, info.node_name) for info in readers}
    return sorted(
        f'{namespace.rstrip("/")}/{name}'
        for namespace, name in {
            (i.node_namespace, i.node_name) for i in publishers if known_node(i)
        }
        if (namespace, name) in listening
    )


class Handshake:
    """Asks each of some nodes the harmless question until it has answered (module docstring).

    Make it after every reader of ``node``: a node that has answered has matched them all.
    ``names``: the nodes, absolute or relative to ``node``'s namespace. Whoever spins ``node``
    completes the calls; :meth:`silent` never blocks.
    """

    def __init__(self, node: Node, names: Iterable[str]) -> None:
        self._node = node
        self._clients = [
            node.create_client(GetParameters, f'{name}/get_parameters') for name in names
        ]
        self._asked: dict[int, RepeatedCall] = {}

    def destroy(self) -> None:
        """Destroy its clients (once every answer that matters has come)."""
        for client in self._clients:
            self._node.destroy_client(client)
        self._clients, self._asked = [], {}

    def silent(self) -> list[str]:
        """The services (resolved names) that have not answered yet; asks those that are up."""
        silent = []
        for index, client in enumerate(self._clients):
            call = self._asked.get(index)
            if call is None and client.service_is_ready():
                call = self._asked[index] = RepeatedCall(client, GetParameters.Request())
            if call is None or call.answer() is None:
                silent.append(client.service_name)
        return silent


class Ready:
    """Publishes ``~/ready`` on ``node`` once each of the nodes ``names`` has answered it.

    Make it after every reader of ``node``; ``names`` as for :class:`Handshake`.
    """

    def __init__(self, node: Node, names: Iterable[str]) -> None:
        self._node = node
        self._handshake = Handshake(node, names)
        self._publisher = node.create_publisher(Bool, READY, HANDED_OVER_QOS)
        # the steady clock: under use_sim_time a timer waits for /clock, which may stand still
        # until we are ready
        steady = Clock(clock_type=ClockType.STEADY_TIME)
        self._timer = node.create_timer(POLL, self._check, clock=steady)
        self._notice_at = time.monotonic() + NOTICE

    def _check(self) -> None:
        silent = self._handshake.silent()
        if silent:
            if self._notice_at is not None and time.monotonic() >= self._notice_at:
                self._notice_at = None
                self._node.get_logger().info(
                    f'not ready: no answer yet from {", ".join(silent)} (asking until it comes)'
                )
            return
        self._node.destroy_timer(self._timer)
        self._node.get_logger().info('every node we listen to has matched our readers: ready')
        self._publisher.publish(Bool(data=True))


class ReadyWatch:
    """What the ``~/ready`` of each of the nodes ``names`` says, heard on ``node``."""

    def __init__(self, node: Node, names: Iterable[str]) -> None:
        self.said = dict.fromkeys(names, False)
        for name in self.said:
            node.create_subscription(
                Bool, ready_topic(name), functools.partial(self._hear, name), HANDED_OVER_QOS
            )

    def _hear(self, name: str, message: Bool) -> None:
        self.said[name] = message.data

    def ready(self) -> bool:
        """Whether every one of them has said it is ready."""
        return all(self.said.values())
