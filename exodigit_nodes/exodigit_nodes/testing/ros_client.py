"""The rclpy node behind :class:`~.client.GloveSim`: topics and services of one glove, as queues.

Kept apart from :mod:`.client` so that importing the testing kit (and its pytest plugin) does not
import rclpy until a glove is started.
"""

from __future__ import annotations

from collections import deque
from collections.abc import Mapping
from typing import Any

import numpy as np
from diagnostic_msgs.msg import DiagnosticStatus
from rcl_interfaces.srv import SetParameters
from rclpy.node import Node
from rclpy.parameter import Parameter
from sensor_msgs.msg import JointState
from std_msgs.msg import Float64MultiArray
from std_srvs.srv import SetBool, Trigger

from ..nodes.catalog import ESTIMATOR_NODE, PLANT_NODE
from ..nodes.handshake import Handshake, ReadyWatch, endpoint_id, known_node
from ..nodes.messages import (
    APPLIED_COMMAND,
    CHAMBER_PRESSURE,
    CONTACT_FORCES,
    ESTIMATED_CONTACT_FORCES,
    JOINT_STATES,
    LOCKSTEP_CONTROLLERS,
    PRESSURE_COMMAND,
    RESET,
    RESET_SIMULATION,
    SEGMENT_LENGTHS,
    SET_PAUSED,
    STEP,
    VALVE_COMMAND,
    fill,
    joint_vector_message,
    valve_command_message,
)
from ..nodes.qos import HANDED_OVER_QOS, RECORD_QOS, STREAM_QOS, record_profile
from ..runner.horizon import Horizon
from .records import SimState


def stamp_ns(message: JointState) -> int:
    """The header stamp of a state or an estimate, ns."""
    return message.header.stamp.sec * 10**9 + message.header.stamp.nanosec


class GloveClient(Node):
    """Queues of the glove's outputs, a command publisher and the plant's service clients.

    Parameters
    ----------
    namespace : str
        The glove's namespace (absolute).
    context : rclpy.Context
        The kit's own context.
    estimator : bool
        Whether an estimator runs (its estimates are part of each state).
    rate_hz : float
        The plant's step rate.
    valves : bool
        The plant takes ``valve_command`` (six openings), not ``pressure_command``.
    """

    def __init__(
        self, namespace: str, context, *, estimator: bool, rate_hz: float, valves: bool
    ) -> None:
        super().__init__('glove_sim_client', namespace=namespace, context=context)
        self.queues: dict[str, deque] = {
            JOINT_STATES: deque(),
            CHAMBER_PRESSURE: deque(),
            CONTACT_FORCES: deque(),
            SEGMENT_LENGTHS: deque(),
        }
        self.estimates: deque | None = deque() if estimator else None
        """The estimator's estimates (stamp in ns, forces in N), oldest first."""
        self.commands: deque = deque()
        self.create_subscription(JointState, JOINT_STATES, self._joint_queue, RECORD_QOS)
        for topic in self.queues:
            if topic != JOINT_STATES:
                self.create_subscription(
                    Float64MultiArray, topic, self._vector_queue(topic), RECORD_QOS
                )
        if estimator:
            self.create_subscription(
                JointState, ESTIMATED_CONTACT_FORCES, self._estimate_queue, RECORD_QOS
            )
        self.command_topic = VALVE_COMMAND if valves else PRESSURE_COMMAND
        # The commands as the plant took them (applied_command), not as a controller sent them:
        # a volatile controller's first commands reach a reader only once its writer has matched
        # that reader, which can come after our reader has matched it (a CI run heard none of
        # 20 answers the plant had taken). The plant's record is transient-local: it starts
        # with the vent the plant applies before any command.
        self.create_subscription(
            Float64MultiArray,
            APPLIED_COMMAND,
            self._vector_queue(None),
            record_profile(APPLIED_COMMAND),
        )
        self.lockstep_controllers: dict[str, set[str]] = {}
        """The controllers the plant has matched both ways, with the ids of their command
        publishers (its ``lockstep_controllers``)."""
        self.create_subscription(
            DiagnosticStatus, LOCKSTEP_CONTROLLERS, self._take_controllers, HANDED_OVER_QOS
        )
        self.command_message = valve_command_message() if valves else joint_vector_message()
        self.publisher = self.create_publisher(Float64MultiArray, self.command_topic, STREAM_QOS)
        plant = f'{namespace.rstrip("/")}/plant'
        self.reset_client = self.create_client(Trigger, RESET)
        self.reset_simulation_client = self.create_client(Trigger, RESET_SIMULATION)
        self.step_client = self.create_client(Trigger, STEP)
        self.pause_client = self.create_client(SetBool, SET_PAUSED)
        self.parameter_client = self.create_client(SetParameters, f'{plant}/set_parameters')
        self.horizon = Horizon(self, plant, period=1.0 / rate_hz)
        """Holds the plant at most `LEAD_STEPS` ahead of the states received in a :meth:`run`."""
        # The session protocol (nodes/handshake.py), after every reader of ours: the glove's
        # nodes have matched our readers once they have answered, and the estimator says on its
        # ~/ready when the plant has matched its own.
        nodes = [PLANT_NODE.executable, *([ESTIMATOR_NODE.executable] if estimator else [])]
        self.handshake = Handshake(self, nodes)
        self.listeners = ReadyWatch(self, nodes[1:])
        self.plant_services = (
            self.reset_client,
            self.reset_simulation_client,
            self.step_client,
            self.pause_client,
            self.parameter_client,
        )

    def _take_controllers(self, message: DiagnosticStatus) -> None:
        self.lockstep_controllers = {
            value.key: set(value.value.split()) for value in message.values
        }

    def _joint_queue(self, message: JointState) -> None:
        self.queues[JOINT_STATES].append(message)

    def _estimate_queue(self, message: JointState) -> None:
        self.estimates.append((stamp_ns(message), np.array(message.effort)))

    def _vector_queue(self, topic: str | None):
        queue = self.commands if topic is None else self.queues[topic]

        def callback(message: Float64MultiArray) -> None:
            queue.append(np.array(message.data))

        return callback

    # -- connection ------------------------------------------------------------------------

    def connected(self) -> bool:
        """Whether the session protocol is through and the plant's services are up.

        The glove's nodes have matched our readers (:attr:`handshake`), the plant has matched the
        estimator's (its ``~/ready``: an estimator the plant does not know yet would miss the
        first state and never estimate it; a kit's first reset waited for that estimate in
        vain), and our commands reach the plant.
        """
        return (
            not self.handshake.silent()
            and self.listeners.ready()
            and self.publisher.get_subscription_count() > 0
            and all(client.service_is_ready() for client in self.plant_services)
        )

    def other_controllers(self) -> dict[str, set[str]]:
        """The other nodes that publish this glove's commands, with their publishers' ids.

        The graph's count of publishers first: it is cheap, and asked before every ``step``.
        """
        if self.count_publishers(self.publisher.topic_name) <= 1:  # ours alone
            return {}
        me = (self.get_name(), self.get_namespace())
        others: dict[str, set[str]] = {}
        for name, info in self._command_publishers():
            if (info.node_name, info.node_namespace) != me and known_node(info):
                others.setdefault(name, set()).add(endpoint_id(info))
        return others

    def _command_publishers(self) -> list[tuple[str, object]]:
        """The graph's publishers of ``pressure_command``: (namespace/name, endpoint info)."""
        return [
            (f'{info.node_namespace.rstrip("/")}/{info.node_name}', info)
            for info in self.get_publishers_info_by_topic(self.publisher.topic_name)
        ]

    # -- states and commands ---------------------------------------------------------------

    def take_state(self, *, with_estimate: bool = True) -> SimState | None:
        """The oldest complete step (one message of each output), or None if it is not here.

        ``with_estimate`` (with an estimator): complete only with the estimate stamped with the
        step's stamp. Estimates of earlier steps are dropped, whether taken or not: one of a
        run's states that arrives late is never taken for a later step's. A step whose estimate
        can no longer come (a later step's came: the estimator answers in order, so it missed
        or refused this one) is dropped too, so that it cannot block every later step.
        """
        while all(self.queues.values()):
            stamp = stamp_ns(self.queues[JOINT_STATES][0])
            estimate = None
            if self.estimates is not None:
                while self.estimates and self.estimates[0][0] < stamp:
                    self.estimates.popleft()
                if self.estimates and self.estimates[0][0] == stamp:
                    estimate = self.estimates[0][1]
                elif with_estimate and not self.estimates:
                    return None
            joint = self.queues[JOINT_STATES].popleft()
            state = SimState(
                t=stamp / 1e9,
                q=np.array(joint.position),
                qdot=np.array(joint.velocity),
                effort=np.array(joint.effort),
                pressure=self.queues[CHAMBER_PRESSURE].popleft(),
                forces=self.queues[CONTACT_FORCES].popleft(),
                lengths=self.queues[SEGMENT_LENGTHS].popleft(),
                estimated_forces=estimate if with_estimate else None,
            )
            if estimate is not None or not with_estimate or self.estimates is None:
                return state
        return None

    def send(self, command: np.ndarray) -> None:
        """Publish one command (Pa, or openings)."""
        self.publisher.publish(fill(self.command_message, command))

    def clear_commands(self) -> None:
        """Forget the commands the plant has applied so far."""
        self.commands.clear()

    def command_publishers(self) -> str:
        """The graph's publishers of this glove's commands, for an error message."""
        names = [name for name, _ in self._command_publishers()]
        return f'the graph lists {", ".join(names) or "no"} publishers of {self.command_topic}'

    def command_count(self) -> int:
        """Commands the plant took (``applied_command``) since the last :meth:`clear_commands`."""
        return len(self.commands)

    def take_commands(self, count: int) -> list[np.ndarray]:
        """The oldest ``count`` applied commands, removed."""
        return [self.commands.popleft() for _ in range(count)]

    # -- requests --------------------------------------------------------------------------

    @staticmethod
    def trigger() -> Trigger.Request:
        """A std_srvs/Trigger request."""
        return Trigger.Request()

    @staticmethod
    def pause_request(paused: bool) -> SetBool.Request:
        """A ``set_paused`` request."""
        return SetBool.Request(data=paused)

    @staticmethod
    def parameters_request(values: Mapping[str, Any]) -> SetParameters.Request:
        """Set the plant's parameters ``values`` (name: Python value)."""
        return SetParameters.Request(
            parameters=[
                Parameter(name, value=value).to_parameter_msg() for name, value in values.items()
            ]
        )

    @staticmethod
    def time_ns(seconds: float) -> int:
        """A stamp in seconds back in nanoseconds (stamps are whole nanoseconds)."""
        return round(seconds * 1e9)
