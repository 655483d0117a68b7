"""Many glove nodes in one process, started one at a time by a test (:class:`NodeHost`).

A node process costs about a second of CPU before it spins (numba, scipy and the model's
kernels), as much as a short test itself. A test that starts many nodes to check how they
find each other (every start order of a glove, 18 nodes) runs them here instead: one process
that imports all that once and builds each node when the test asks, in the process's one rclpy
context, as ``hand_nodes`` runs the nodes of a hand. Each node keeps its own name, namespace,
parameters, topics and services; a node built later joins the graph later, exactly as a node
process started later does.

Protocol (run as a script: ``python node_host.py``, ROS_DOMAIN_ID from the environment): one
JSON line per node on stdin, ``{"executable": "plant", "namespace": "/order0", "parameters":
{...}}``; the host answers one line on stdout, ``started <namespace>/<executable>`` once the
node exists and spins, or ``refused <reason>``. At the end of stdin it destroys the nodes and
exits 0. Every node spins on one SingleThreadedExecutor in a second thread (rclpy's executor
takes nodes added while it spins; its EventsExecutor, which the plant uses in its own process,
is not documented to).
"""

from __future__ import annotations

import contextlib
import json
import select
import subprocess
import sys
import threading
from pathlib import Path

from exodigit_nodes.logic.ros_env import ros_args
from exodigit_nodes.testing.processes import ros_environment

HOST = Path(__file__).resolve()
START_TIMEOUT = 30.0
"""Longest wait for the host to build a node, s (the first one imports the model)."""
STOP_TIMEOUT = 10.0
"""Longest wait for the host to destroy its nodes and exit, s; then it is killed."""


class NodeHost:
    """The host process in ``domain_id`` (its stderr in ``workdir``); :meth:`start` a node in it.

    Has the :meth:`start` of :class:`ros_harness.NodeLauncher`, so a
    :class:`reliability_session.GloveSession` can take either.
    """

    def __init__(self, domain_id: int, workdir: Path) -> None:
        self.errors = Path(workdir) / 'node_host.err'
        with open(self.errors, 'w') as errors:
            self.process = subprocess.Popen(
                [sys.executable, str(HOST)],
                env=ros_environment(domain_id),
                cwd=workdir,
                stdin=subprocess.PIPE,
                stdout=subprocess.PIPE,
                stderr=errors,
                text=True,
            )

    def start(self, executable: str, parameters: dict, namespace: str) -> str:
        """Build node ``executable`` in ``namespace`` with ``parameters``; its full name."""
        request = {'executable': executable, 'namespace': namespace, 'parameters': parameters}
        self.process.stdin.write(json.dumps(request) + '\n')
        self.process.stdin.flush()
        ready, _, _ = select.select([self.process.stdout], [], [], START_TIMEOUT)
        answer = self.process.stdout.readline().strip() if ready else 'no answer'
        if not answer.startswith('started '):
            raise RuntimeError(f'node host: {executable} in {namespace}: {answer}\n{self.log()}')
        return answer.removeprefix('started ')

    def log(self) -> str:
        """What the host and its nodes wrote on stderr (their log lines)."""
        return self.errors.read_text()

    def close(self) -> int:
        """End stdin: the host destroys its nodes and exits (killed after STOP_TIMEOUT)."""
        self.process.stdin.close()
        try:
            return self.process.wait(STOP_TIMEOUT)
        except subprocess.TimeoutExpired:
            self.process.kill()
            return self.process.wait()


def main() -> int:
    import rclpy
    from exodigit_nodes.nodes.catalog import NODES
    from exodigit_nodes.nodes.dds import use_profile
    from exodigit_nodes.nodes.node_base import ConfigurationError
    from rclpy.executors import ExternalShutdownException, SingleThreadedExecutor
    from ros_harness import SPIN_PERIOD

    stop = threading.Event()

    def spin() -> None:  # ends before the executor is shut down (ros_harness.RosProbe.close)
        with contextlib.suppress(ExternalShutdownException):
            while not stop.is_set():
                executor.spin_once(timeout_sec=SPIN_PERIOD)

    classes = {entry.executable: entry for entry in NODES}
    use_profile()
    rclpy.init()
    executor = SingleThreadedExecutor()
    spinner = threading.Thread(target=spin, daemon=True)
    spinner.start()
    nodes = []
    try:
        for line in sys.stdin:
            request = json.loads(line)
            args = ros_args(request['parameters'], request['namespace'])
            try:
                node = classes[request['executable']].node_class()(cli_args=args)
            except ConfigurationError as error:
                print(f'refused {error}', flush=True)
                continue
            nodes.append(node)
            executor.add_node(node)
            print(f'started {node.get_fully_qualified_name()}', flush=True)
    finally:
        stop.set()
        spinner.join(STOP_TIMEOUT)
        executor.shutdown()
        for node in nodes:
            node.destroy_node()
        rclpy.try_shutdown()
    return 0


if __name__ == '__main__':
    sys.exit(main())
