"""ROS wiring of the glove's live summary: subscribes to every glove topic, feeds `GloveSignals`.

The node only converts messages to arrays; what is joined, shown and recorded is decided by
`exodigit_nodes.runner.summary` and `exodigit_nodes.runner.run_record`.
"""

import time
from collections.abc import Callable
from functools import partial

import numpy as np
from diagnostic_msgs.msg import DiagnosticArray
from rclpy.node import Node
from sensor_msgs.msg import JointState
from std_msgs.msg import Float64MultiArray

from exodigit_nodes.logic.inputs import sent_seconds, stamp_seconds
from exodigit_nodes.nodes.message_info import WithInfo
from exodigit_nodes.nodes.messages import APPLIED_COMMAND, DIAGNOSTICS
from exodigit_nodes.nodes.qos import RECORD_QOS, record_profile
from exodigit_nodes.runner.summary import (
    COMMAND_SIGNALS,
    ESTIMATE,
    JOINT_LABELS,
    SIGNALS,
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
        Called with each completed `Sample` (one per plant step).
    **node_options
        Passed to :class:`rclpy.node.Node` (``context``).
    """

    def __init__(
        self,
        signals: GloveSignals,
        namespace: str,
        on_sample: Callable[[Sample], None],
        **node_options,
    ) -> None:
        super().__init__('glove_monitor', namespace=namespace, **node_options)
        self._signals = signals
        self._on_sample = on_sample
        self.taken = 0
        """Messages this monitor has taken so far (signals and /diagnostics)."""
        # A step's command is what the plant applied, not what a controller sent
        # (docs/spec/ros.md, "The session protocol", guarantee 4).
        self.create_subscription(
            Float64MultiArray,
            APPLIED_COMMAND,
            WithInfo(self._on_applied_command),
            record_profile(APPLIED_COMMAND),
        )
        for topic in SIGNALS:
            if topic in COMMAND_SIGNALS:
                continue
            if topic == 'joint_states':
                message_type, callback = JointState, partial(self._on_state, topic, 'position')
            elif topic == ESTIMATE:
                message_type, callback = JointState, partial(self._on_state, topic, 'effort')
            else:
                message_type, callback = Float64MultiArray, partial(self._on_array, topic)
            self.create_subscription(message_type, topic, WithInfo(callback), RECORD_QOS)
        self.create_subscription(DiagnosticArray, DIAGNOSTICS, self._on_diagnostics, RECORD_QOS)

    def _on_array(self, topic: str, message: Float64MultiArray, info: dict) -> None:
        self._update(topic, message.data, info)

    def _on_state(self, topic: str, field: str, message: JointState, info: dict) -> None:
        """Angles (``position``) or an estimate (``effort``), with the state's stamp."""
        stamp = stamp_seconds(message.header.stamp)
        self._update(topic, getattr(message, field), info, stamp)

    def _on_applied_command(self, message: Float64MultiArray, info: dict) -> None:
        """Three pressures (a regulator's command) or six openings (valves: shown net)."""
        if len(message.data) == VALVE_OPENINGS:
            self._update('valve_command', net_openings(message.data), info)
        else:
            self._update('pressure_command', message.data, info)

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
