"""A listener to run inside a network namespace: prints one JSON line per message it receives.

``python tests/reliability_netns_probe.py TOPIC...`` subscribes (glove QoS) to each topic, typed
by its name (``joint_states``: JointState, an estimate: JointState, ``/diagnostics``:
DiagnosticArray, anything else: Float64MultiArray), and writes ``{"topic": ..., "values": [...]}``
for vectors, joint positions and estimates (their effort), ``{"topic": "/diagnostics", "name":
..., "message": ..., "values": {...}}`` for each diagnostic status. The two-host test reads
these lines from the namespace it cannot enter.
"""

import json
import sys

import rclpy
from diagnostic_msgs.msg import DiagnosticArray
from exodigit_nodes.nodes.qos import READER_QOS
from rclpy.executors import ExternalShutdownException
from sensor_msgs.msg import JointState
from std_msgs.msg import Float64MultiArray


def emit(record: dict) -> None:
    sys.stdout.write(json.dumps(record) + '\n')
    sys.stdout.flush()


def listener(topic: str):
    """Message type and callback printing one record per message of ``topic``."""
    if topic == '/diagnostics':

        def diagnostics(message: DiagnosticArray) -> None:
            for status in message.status:
                values = {kv.key: kv.value for kv in status.values}
                emit({'topic': topic, 'name': status.name, 'message': status.message,
                      'values': values})  # fmt: skip

        return DiagnosticArray, diagnostics
    if topic.endswith('joint_states'):
        return JointState, lambda m: emit({'topic': topic, 'values': list(m.position)})
    if topic.endswith(('estimated_contact_forces', 'estimated_finger_torque')):
        return JointState, lambda m: emit({'topic': topic, 'values': list(m.effort)})
    return Float64MultiArray, lambda m: emit({'topic': topic, 'values': list(m.data)})


def main(topics: list[str]) -> int:
    """Listen to ``topics`` until SIGINT or SIGTERM/SIGKILL."""
    try:
        rclpy.init()
        node = rclpy.create_node('netns_probe')
        for topic in topics:
            kind, callback = listener(topic)
            node.create_subscription(kind, topic, callback, READER_QOS)
        rclpy.spin(node)
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    finally:
        rclpy.try_shutdown()
    return 0


if __name__ == '__main__':
    raise SystemExit(main(sys.argv[1:]))
