"""The session protocol: who must be present, the one handshake, and ``~/ready``.

No plant of a session steps until every node that publishes has matched every reader that must
get all of it: docs/spec/ros.md, "The session protocol", gives the sequence, why each step holds
and the test of each guarantee. :class:`Handshake` is guarantee 1 (a node that answered has
matched the asker's readers and writers), :class:`Ready` guarantee 2 (a listener says so on
``~/ready``), :class:`ReadyWatch` the runners' and the testing kit's side of guarantee 3, and
:class:`Controllers` the plant's side of guarantee 5 (whom lockstep counts as a controller).
"""

from __future__ import annotations

import functools
import time
from collections.abc import Iterable

from rcl_interfaces.srv import GetParameters
from rclpy.clock import Clock, ClockType
from rclpy.node import Node
from std_msgs.msg import Bool

from .qos import HANDED_OVER_QOS
from .repeated_call import RepeatedCall

POLL = 0.05
"""How often a :class:`Ready` node looks for the answers until it is ready, s."""
NOTICE = 3.0
"""Wall seconds without every answer before a :class:`Ready` node says, once, whom it waits for."""
UNKNOWN_NODE = '_NODE_NAME_UNKNOWN_'
"""What the graph names an endpoint whose node has not been announced yet (rmw)."""


def glove_nodes(namespaces: Iterable[str], names: Iterable[str]) -> list[str]:
    """The nodes ``names`` of every glove of ``namespaces``: ``<namespace>/<name>``.

    A namespace is absolute (``/hand/index``), relative to the asking node's (``index``), or ''
    for the asking node's own.
    """
    names = list(names)
    return [
        f'{namespace.rstrip("/")}/{name}' if namespace.strip('/') else name
        for namespace in namespaces
        for name in names
    ]


def known_node(info) -> bool:
    """Whether a graph endpoint's node is known by name yet (its participant announced it)."""
    return info.node_name != UNKNOWN_NODE


PARTICIPANT_DIGITS = 24
"""Hex digits of an :func:`endpoint_id` that name its participant (the GUID prefix, 12 bytes)."""


def endpoint_id(info) -> str:
    """A graph endpoint's GID in hex: it tells an endpoint from one a namesake had before it."""
    return bytes(info.endpoint_gid).hex()


def matched_every_listed(node: Node, publisher, least: int = 0) -> bool:
    """Whether ``publisher`` of ``node`` has matched every subscriber the graph lists (>= least).

    The graph lists a subscriber once ``node``'s participant has discovered it; the match can
    follow a moment later.
    """
    listed = node.count_subscribers(publisher.topic_name)
    return publisher.get_subscription_count() >= max(listed, least)


def controllers_matched(node: Node, commands, states) -> dict[str, str]:
    """Nodes that publish on ``commands`` and read ``states``, both matched with ``node``.

    ``commands`` is a subscription of ``node``, ``states`` one of its publishers; nobody until
    the subscription has matched every publisher the graph lists. Keyed by fully qualified
    name, sorted; each with the :func:`endpoint_id` of its ``commands`` publishers, space
    separated (a node that has restarted under its name has new ones). A node whose name the
    graph does not know yet is left out.
    """
    if node.count_publishers(commands.topic_name) > commands.get_publisher_count():
        return {}
    readers = node.get_subscriptions_info_by_topic(states.topic_name)
    listening = {(i.node_namespace, i.node_name) for i in readers}
    sending: dict[str, list[str]] = {}
    for info in node.get_publishers_info_by_topic(commands.topic_name):
        if known_node(info) and (info.node_namespace, info.node_name) in listening:
            name = f'{info.node_namespace.rstrip("/")}/{info.node_name}'
            sending.setdefault(name, []).append(endpoint_id(info))
    return {name: ' '.join(sorted(ids)) for name, ids in sorted(sending.items())}


class Handshake:
    """Asks each of the nodes ``names`` ``get_parameters`` of no name until it has answered.

    Make it after every reader of ``node``: a node that has answered has matched them all.
    ``names`` are absolute or relative to ``node``'s namespace. Whoever spins ``node``
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


class Controllers:
    """The nodes that publish ``commands`` and read ``states`` of ``node``, matched both ways.

    ``commands`` is a subscription of ``node``, ``states`` one of its publishers
    (:func:`controllers_matched`); a node of another participant only once it has answered our
    :class:`Handshake`. An answer says that the node has matched every endpoint ``node`` made
    before asking, its writers too: a participant announces its readers and its writers each in
    the order it made them, and the request reached the node through its match of our request
    writer (so its reader of ``states`` gets what we send from then on, which our own match of
    it does not say). Each is asked once per key, its name and the ids of its endpoints (a
    namesake that has restarted is asked anew); the handshakes of nodes no longer matched are
    destroyed. A node of our own participant is not asked: a participant matches its own
    endpoints at once, both ways. Whoever spins ``node`` completes the calls.
    """

    def __init__(self, node: Node, commands, states) -> None:
        self._node, self._commands, self._states = node, commands, states
        self._participant = ''
        self._asked: dict[tuple[str, str], Handshake] = {}

    def matched(self) -> dict[str, str]:
        """Name: ids (:func:`controllers_matched`) of each; asks those not asked yet.

        None before the graph lists ``states`` (our participant still unknown).
        """
        if not self._participant:
            me = (self._node.get_name(), self._node.get_namespace())
            infos = self._node.get_publishers_info_by_topic(self._states.topic_name)
            ours = [endpoint_id(i) for i in infos if (i.node_name, i.node_namespace) == me]
            if not ours:
                return {}
            self._participant = ours[0][:PARTICIPANT_DIGITS]
        nodes = controllers_matched(self._node, self._commands, self._states)
        others = {
            name: ids
            for name, ids in nodes.items()
            if any(i[:PARTICIPANT_DIGITS] != self._participant for i in ids.split())
        }
        for key in self._asked.keys() - others.items():
            self._asked.pop(key).destroy()
        for key in others.items() - self._asked.keys():
            self._asked[key] = Handshake(self._node, key[:1])
        return {
            name: ids
            for name, ids in nodes.items()
            if name not in others or not self._asked[name, ids].silent()
        }


class Ready:
    """Publishes ``True`` on ``~/ready`` of ``node`` once each of ``names`` has answered it.

    Latched (:data:`.qos.HANDED_OVER_QOS`) and logged; after :data:`NOTICE` s without every
    answer it logs, once, whom it still waits for. Make it after every reader of ``node``;
    ``names`` as for :class:`Handshake`.
    """

    def __init__(self, node: Node, names: Iterable[str]) -> None:
        self._node = node
        self._handshake = Handshake(node, names)
        self._publisher = node.create_publisher(Bool, '~/ready', HANDED_OVER_QOS)
        # steady: under use_sim_time a ROS timer waits for /clock, which stands still until then
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
                Bool, f'{name}/ready', functools.partial(self._hear, name), HANDED_OVER_QOS
            )

    def _hear(self, name: str, message: Bool) -> None:
        self.said[name] = message.data

    def ready(self) -> bool:
        """Whether every one of them has said it is ready."""
        return all(self.said.values())
