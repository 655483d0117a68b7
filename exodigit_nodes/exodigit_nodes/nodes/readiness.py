"""``~/ready``: a node says when the plants it listens to have matched all its readers.

A plant takes a requested step as soon as its outputs have matched every subscriber *it* knows
of. Discovery is per pair of processes: a reader that another process already lists may be
unknown to the plant for a while, and a volatile reader misses what the plant sends meanwhile
(the testing kit waited forever for the estimate of a reset the estimator never heard), while a
plant in simulated time can end a short session before it knows of a recorder at all.

So the node asks each plant a harmless question (its ``rate_hz``) on a client made after all its
readers: Fast DDS announces a participant's endpoints in the order they were made, on one
reliable stream, so a plant that answers has matched them all. Once every plant has answered,
the node publishes ``True`` on ``~/ready`` (std_msgs/Bool, transient-local, depth 1) and logs it.
Whoever must not start the plants before (the runners, for the recorder; the testing kit, for
the estimator) waits for it. A node that listens to no plant of ours never says it; after
:data:`NOTICE` seconds it logs, once, which plants have not answered.

The runners ask the same of every node of every glove (:class:`Answers`, on a client made after
the live summary's readers) before they resume the plants: reader-side matching says nothing of
the writer's side, and a controller whose publisher matched the summary late left a run record
without a command in any of its 100 rows (a valves session in a CI run).
"""

from __future__ import annotations

import time

from rcl_interfaces.srv import GetParameters
from rclpy.clock import Clock, ClockType
from rclpy.node import Node
from std_msgs.msg import Bool

from .catalog import PLANT_NODE
from .messages import rate_request
from .qos import HANDED_OVER_QOS
from .repeated_call import RepeatedCall

READY = '~/ready'
"""The topic, private to the node (``/hand/recorder/ready``)."""
POLL = 0.05
"""How often the node looks for the plants' answers until it is ready, s."""
NOTICE = 3.0
"""Wall seconds without every plant's answer before the node says, once, whom it waits for."""


def ready_topic(node: str) -> str:
    """The ``~/ready`` topic of the node named ``node`` (absolute, or relative to the reader's)."""
    return f'{node}/{READY.removeprefix("~/")}'


class Answers:
    """Asks each of some nodes a harmless question until it has answered (module docstring).

    Make it after every reader of ``node``: a node that has answered has matched them all, so
    its publishers send those readers everything from then on. ``names``: the nodes, absolute
    or relative to ``node``'s namespace.
    """

    def __init__(self, node: Node, names) -> None:
        self._clients = [
            node.create_client(GetParameters, f'{name}/get_parameters') for name in names
        ]
        self._asked: dict[int, RepeatedCall] = {}

    def silent(self) -> list[str]:
        """The services (resolved names) that have not answered yet; asks those that are up."""
        silent = []
        for index, client in enumerate(self._clients):
            call = self._asked.get(index)
            if call is None and client.service_is_ready():
                call = self._asked[index] = RepeatedCall(client, rate_request())
            if call is None or call.answer() is None:
                silent.append(client.service_name)
        return silent


class PlantReadiness:
    """Publishes ``~/ready`` on ``node`` once the plant of each namespace has answered it.

    Make it after every reader of ``node``. ``namespaces``: relative to the node's own, one per
    plant ('' for the plant beside it, ``index`` for ``<ns>/index/plant``).
    """

    def __init__(self, node: Node, namespaces: tuple[str, ...]) -> None:
        self._node = node
        self._plants = Answers(
            node, [f'{namespace}/{PLANT_NODE.executable}'.lstrip('/') for namespace in namespaces]
        )
        self._publisher = node.create_publisher(Bool, READY, HANDED_OVER_QOS)
        # the steady clock: under use_sim_time a timer waits for /clock, which may stand still
        # until we are ready
        steady = Clock(clock_type=ClockType.STEADY_TIME)
        self._timer = node.create_timer(POLL, self._check, clock=steady)
        self._notice_at = time.monotonic() + NOTICE

    def _check(self) -> None:
        silent = self._plants.silent()
        if silent:
            if self._notice_at is not None and time.monotonic() >= self._notice_at:
                self._notice_at = None
                self._node.get_logger().info(
                    f'not ready: no answer yet from {", ".join(silent)} (asking until it comes)'
                )
            return
        self._node.destroy_timer(self._timer)
        self._node.get_logger().info('every plant has matched our readers: ready')
        self._publisher.publish(Bool(data=True))
