"""ROS wiring of the glove's live summary: subscribes to every glove topic, feeds `GloveSignals`.

The node only converts messages to arrays; what is joined, shown and recorded is decided by
`exodigit_nodes.runner.summary` and `exodigit_nodes.runner.run_record`.
"""

import time
from collections.abc import Callable

import numpy as np
from diagnostic_msgs.msg import DiagnosticArray
from rclpy.node import Node
from sensor_msgs.msg import JointState
from std_msgs.msg import Float64MultiArray
from std_srvs.srv import SetBool

from exodigit_nodes.logic.backlog import take_backlog
from exodigit_nodes.logic.inputs import sent_seconds, stamp_seconds
from exodigit_nodes.nodes.message_info import WithInfo
from exodigit_nodes.nodes.messages import APPLIED_COMMAND, DIAGNOSTICS, SET_PAUSED
from exodigit_nodes.nodes.qos import RECORD_QOS, record_profile
from exodigit_nodes.runner.summary import (
    COMMAND_SIGNALS,
    JOINT_LABELS,
    SIGNALS,
    STAMPED,
    VALVE_OPENINGS,
    GloveSignals,
    Sample,
    net_openings,
)


def status_node(status_name: str, namespace: str, nodes) -> str | None:
    """The node of ``nodes`` in ``namespace`` a diagnostic status name belongs to, if any.

    Status names start with the node's fully qualified name (``/glove/plant: solver``); the
    namespace check keeps other gloves on the same domain out of this summary.
    """
    for node in nodes:
        qualified = f'{namespace.rstrip("/")}/{node}'
        if status_name == qualified or status_name.startswith((qualified + ':', qualified + ' ')):
            return node
    return None


class GloveMonitor(Node):
    """Subscribes to the glove's topics in one namespace and hands their values on.

    Parameters
    ----------
    signals : GloveSignals
        Receives every value; its health table names the nodes watched on ``/diagnostics``.
    namespace : str
        The glove's namespace (absolute).
    on_sample : callable
        Called with each completed `Sample` (one per plant step). Subscriptions take the DDS
        message info: its source timestamp (when a message was sent) joins the three messages of
        a plant step.
    pause_service : str
        The ``set_paused`` service of the glove's simulated time (a hand's is the hand's).
    **node_options
        Passed to :class:`rclpy.node.Node` (``context``).
    """

    def __init__(
        self,
        signals: GloveSignals,
        namespace: str,
        on_sample: Callable[[Sample], None],
        *,
        pause_service: str = SET_PAUSED,
        **node_options,
    ):
        super().__init__('glove_monitor', namespace=namespace, **node_options)
        self._signals = signals
        self._on_sample = on_sample
        self.taken = 0
        """Messages this monitor has taken so far (signals and /diagnostics)."""
        # The command of a step is what the plant applied (its applied_command, kept for late
        # readers), not what a controller sent: a controller's publisher may match us late.
        self.create_subscription(
            Float64MultiArray,
            APPLIED_COMMAND,
            WithInfo(self._on_applied_command),
            record_profile(APPLIED_COMMAND),
        )
        for topic in SIGNALS:
            if topic == 'joint_states':
                callback, message_type = self._on_joint_state, JointState
            elif topic in STAMPED:
                callback, message_type = self._stamped_callback(topic), JointState
            elif topic in COMMAND_SIGNALS:
                continue
            else:
                callback, message_type = self._array_callback(topic), Float64MultiArray
            self.create_subscription(message_type, topic, WithInfo(callback), RECORD_QOS)
        self.create_subscription(DiagnosticArray, DIAGNOSTICS, self._on_diagnostics, RECORD_QOS)
        self._pause_client = self.create_client(SetBool, pause_service)

    def drain(self, spin: Callable[[], None]) -> None:
        """Take what our readers still hold once the nodes stopped (:func:`.take_backlog`).

        ``spin`` is one pass of our executor. A monitor that fell behind holds seconds of the
        nodes' last steps, the chambers' zero pressure among them.
        """
        take_backlog(spin, lambda: self.taken)

    def resume_plant(self) -> bool:
        """Ask a plant started paused to run (``set_paused`` false); False if not there yet."""
        if not self._pause_client.service_is_ready():
            return False
        self._pause_client.call_async(SetBool.Request(data=False))
        return True

    def _array_callback(self, topic: str) -> Callable[[Float64MultiArray, dict], None]:
        def callback(message: Float64MultiArray, info: dict) -> None:
            self._update(topic, message.data, info)

        return callback

    def _stamped_callback(self, topic: str) -> Callable[[JointState, dict], None]:
        def callback(message: JointState, info: dict) -> None:
            self._update(topic, message.effort, info, stamp_seconds(message.header.stamp))

        return callback

    def _on_applied_command(self, message: Float64MultiArray, info: dict) -> None:
        """Three pressures (a regulator's command) or six openings (valves: shown net)."""
        if len(message.data) == VALVE_OPENINGS:
            self._update('valve_command', net_openings(message.data), info)
        else:
            self._update('pressure_command', message.data, info)

    def _on_joint_state(self, message: JointState, info: dict) -> None:
        self._update('joint_states', message.position, info, stamp_seconds(message.header.stamp))

    def _update(self, topic: str, values, info: dict, stamp: float | None = None) -> None:
        self.taken += 1
        values = np.asarray(values, dtype=float)
        if values.shape != (len(JOINT_LABELS),):
            return  # another publisher's malformed message: the nodes report those, not us
        for sample in self._signals.update(topic, values, sent_seconds(info), stamp):
            self._on_sample(sample)

    def _on_diagnostics(self, message: DiagnosticArray) -> None:
        self.taken += 1
        worst: dict[str, tuple[int, str]] = {}
        for status in message.status:
            node = status_node(status.name, self.get_namespace(), self._signals.health)
            if node is None:
                continue
            level = ord(status.level)  # a byte in rclpy
            if node not in worst or level > worst[node][0]:
                worst[node] = (level, status.message)
        now = time.monotonic()
        for node, (level, text) in worst.items():
            self._signals.update_health(node, level, text, now)
