"""Test harness: glove nodes as OS processes, and an in-test rclpy node that talks to them.

Used by every test that needs ROS (tests/conftest.py gives fixtures around it). What it does:

* :func:`claim_domain` picks a ROS_DOMAIN_ID nobody on this machine is using, held with ROS 2's
  ``domain_coordinator`` for the whole test session (ids 1-100, skipping the Makefile's 37), so
  parallel test runs never cross-talk. Discovery stays on
  loopback (``ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST``, :func:`ros_environment`).
* :class:`NodeProcess` starts ``python -m exodigit_nodes.<node> --ros-args ...`` as the runners
  start their nodes (own session, SIGINT then SIGTERM then SIGKILL to stop), in a scratch
  directory (never the repository root), output to log files, and reads CPU time and resident
  memory from /proc.
* :class:`RosProbe` is an rclpy node in its own context, spun by a background thread: record
  topics (:class:`Inbox`), publish, call services, set and get other nodes' parameters
  (rcl_interfaces SetParameters/GetParameters), list topics. Its context is the only one the
  test process opens (:meth:`RosProbe.local_node` gives in-process tests their nodes).
* :func:`wait_until` polls a condition with a timeout: tests never sleep a fixed time.

Example::

    lease = claim_domain()
    probe = RosProbe(lease.domain_id)
    plant = NodeProcess('plant', {'rate_hz': 200.0}, lease.domain_id, workdir, namespace='/t')
    states = probe.subscribe('/t/joint_states', JointState)
    assert states.wait_count(10, timeout=10.0)
    plant.stop()
"""

from __future__ import annotations

import contextlib
import os
import signal
import subprocess
import threading
import time
from collections.abc import Callable, Mapping
from pathlib import Path
from typing import Any

import rclpy
from exodigit_nodes.logic.ros_env import ros_args  # noqa: F401 (public)
from exodigit_nodes.nodes.dds import use_profile
from exodigit_nodes.nodes.handshake import Handshake
from exodigit_nodes.nodes.repeated_call import RepeatedCall
from exodigit_nodes.testing.processes import (  # noqa: F401 (the harness's public names)
    STOP_TIMEOUT,
    DomainLease,
    NodeProcess,
    claim_domain,
    cpu_seconds,
    ros_environment,
)
from rcl_interfaces.srv import (
    DescribeParameters,
    GetParameters,
    ListParameters,
    SetParameters,
)
from rclpy.executors import ExternalShutdownException, SingleThreadedExecutor
from rclpy.impl.implementation_singleton import rclpy_implementation
from rclpy.parameter import Parameter, parameter_value_to_python
from rclpy.qos import QoSProfile, ReliabilityPolicy
from rclpy.signals import SignalHandlerOptions
from std_srvs.srv import SetBool

DISCOVERY_TIMEOUT = 10.0
"""Longest wait for two processes to discover each other, s (median here is 0.45 s)."""
SPIN_PERIOD = 0.05
"""Longest a probe's spin waits before it looks whether it is to stop, s."""
NodeNameNonExistentError = rclpy_implementation.NodeNameNonExistentError
"""What rclpy raises when a graph query names a node that has left (not in its public API)."""
REPEATABLE = (ListParameters, DescribeParameters, GetParameters, SetParameters, SetBool)
"""Service types whose request :meth:`RosProbe.call` sends again when no answer comes: asking
twice has the outcome of asking once (parameters; the plant's ``set_paused``). Not ``Trigger``:
the plant's ``step`` would step twice."""
TEST_QOS = QoSProfile(depth=10_000, reliability=ReliabilityPolicy.RELIABLE)
"""Probe subscriptions: reliable like the glove's topics, deep so a busy test loses nothing (a
probe that holds every topic of a glove fell more than 1,000 steps behind on a loaded machine:
fresh clone fc54 lost 816 of 2,571 contact_forces)."""


def wait_until(condition: Callable[[], Any], timeout: float, interval: float = 0.005) -> Any:
    """Poll ``condition`` until it returns something truthy (returned) or ``timeout`` s pass.

    Returns the last (falsy) value on timeout, so ``assert wait_until(...)`` reads naturally.
    """
    deadline = time.monotonic() + timeout
    while True:
        value = condition()
        if value or time.monotonic() > deadline:
            return value
        time.sleep(interval)


def stop_process(process, timeout: float = 5.0) -> None:
    """Stop a test's controller process: SIGINT (its clean stop), SIGKILL after ``timeout`` s."""
    process.send_signal(signal.SIGINT)
    try:
        process.wait(timeout)
    except subprocess.TimeoutExpired:
        process.kill()
        process.wait()


class NodeLauncher:
    """Starts :class:`NodeProcess` es in one domain and workdir, and stops them all at the end."""

    def __init__(self, domain_id: int, workdir: Path) -> None:
        self.domain_id = domain_id
        self.workdir = Path(workdir)
        self.processes: list[NodeProcess] = []

    def start(
        self, module: str, parameters: Mapping[str, Any] | None = None, **kwargs
    ) -> NodeProcess:
        """Start a node (see :class:`NodeProcess` for the keyword arguments)."""
        node = NodeProcess(module, parameters, self.domain_id, self.workdir, **kwargs)
        self.processes.append(node)
        return node

    def run(self, module: str, parameters=None, timeout: float = 30.0, **kwargs):
        """Start a node and wait for it to exit by itself; returns (status, stdout, stderr)."""
        node = self.start(module, parameters, **kwargs)
        code = node.wait(timeout)
        if code is None:
            code = node.stop()
        return code, node.stdout(), node.stderr()

    def stop_all(self) -> None:
        """Stop every node still running (SIGINT to all, then each escalated if it must be)."""
        for node in self.processes:
            node.signal(signal.SIGINT)
        for node in self.processes:
            node.stop()


# -- the in-test ROS node ------------------------------------------------------------------


class Inbox:
    """Messages received on one topic, with arrival time (``time.monotonic()``) and info.

    ``info`` is rclpy's message info (``source_timestamp``/``received_timestamp`` in ns of the
    system clock) when the probe subscribed ``with_info``, else None.
    """

    def __init__(self) -> None:
        self._lock = threading.Lock()
        self._items: list[tuple[float, Any, dict | None]] = []
        self.subscription = None
        """The probe's subscription that fills it (set by :meth:`RosProbe.subscribe`)."""

    def matched(self) -> int:
        """How many publishers the subscription has matched (our side of the match)."""
        return self.subscription.get_publisher_count()

    def put(self, message, info: dict | None = None) -> None:
        """Store a message (called by the executor thread)."""
        with self._lock:
            self._items.append((time.monotonic(), message, info))

    def records(self) -> list[tuple[float, Any, dict | None]]:
        """A snapshot of (arrival time, message, info), oldest first."""
        with self._lock:
            return list(self._items)

    def messages(self, since: float = -1.0) -> list:
        """Messages that arrived after ``since`` (a ``time.monotonic()`` value)."""
        return [m for t, m, _ in self.records() if t > since]

    def latest(self):
        """The newest message, or None."""
        with self._lock:
            return self._items[-1][1] if self._items else None

    def count(self) -> int:
        """How many have arrived."""
        with self._lock:
            return len(self._items)

    def clear(self) -> None:
        """Forget what has arrived."""
        with self._lock:
            self._items.clear()

    def wait_count(self, n: int, timeout: float = DISCOVERY_TIMEOUT) -> bool:
        """Wait until at least ``n`` messages have arrived."""
        return bool(wait_until(lambda: self.count() >= n, timeout))

    def wait_for(self, predicate: Callable[[Any], bool], timeout: float, since: float = -1.0):
        """The first message after ``since`` that satisfies ``predicate`` (None on timeout)."""

        def find():
            return next((m for m in self.messages(since) if predicate(m)), None)

        return wait_until(find, timeout)


class RosProbe:
    """An rclpy node in its own context, spun in a background thread, for driving tests.

    Parameters
    ----------
    domain_id : int
        ROS_DOMAIN_ID to join (the nodes under test must use the same).
    name : str
        Node name.
    """

    def __init__(self, domain_id: int, name: str = 'exodigit_test_probe') -> None:
        os.environ['ROS_AUTOMATIC_DISCOVERY_RANGE'] = 'LOCALHOST'
        use_profile()
        self.context = rclpy.Context()
        rclpy.init(
            context=self.context,
            domain_id=domain_id,
            signal_handler_options=SignalHandlerOptions.NO,
        )
        self.node = rclpy.create_node(name, context=self.context)
        self.executor = SingleThreadedExecutor(context=self.context)
        self.executor.add_node(self.node)
        self._lock = threading.Lock()
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._spin, daemon=True)
        self._thread.start()

    def _spin(self) -> None:
        with contextlib.suppress(ExternalShutdownException):
            while not self._stop.is_set():
                self.executor.spin_once(timeout_sec=SPIN_PERIOD)

    def close(self) -> None:
        """Stop spinning, then shut the executor and the context down.

        The spinning thread ends before anything it waits on is destroyed: a context shut down
        under an executor still in its wait raised RCLError in that thread, and rclpy 7.1's
        ``Executor.shutdown`` does not wait for a spin in another thread (its wait is skipped)
        before it destroys the guard conditions that spin waits on (AttributeError there).
        """
        self._stop.set()
        self._thread.join()
        self.executor.shutdown()
        self.node.destroy_node()
        rclpy.try_shutdown(context=self.context)

    @contextlib.contextmanager
    def local_node(self, name: str):
        """A node in the probe's context that nothing spins (no parameter services, no rosout).

        In-process tests build their rclpy nodes here rather than in a context of their own: a
        second Fast DDS participant in one process can deadlock while its readers and writers
        are destroyed (eProsima/Fast-DDS#6193), and that hung a CI run.
        """
        with self._lock:
            node = rclpy.create_node(
                name, context=self.context, start_parameter_services=False, enable_rosout=False
            )
        try:
            yield node
        finally:
            with self._lock:
                node.destroy_node()

    # topics

    def subscribe(
        self, topic: str, message_type, with_info: bool = False, qos: QoSProfile = TEST_QOS
    ) -> Inbox:
        """Record every message on ``topic`` (absolute name) in an :class:`Inbox`.

        ``with_info`` keeps rclpy's message info (source timestamps) beside each message.
        ``qos``: volatile by default (it matches any publisher); a transient-local profile
        (``exodigit_nodes.nodes.qos.RECORD_QOS``) also gets what the glove's nodes published
        before it matched.
        """
        inbox = Inbox()
        callback = (lambda message, info: inbox.put(message, info)) if with_info else inbox.put
        with self._lock:
            inbox.subscription = self.node.create_subscription(message_type, topic, callback, qos)
        return inbox

    def publisher(self, topic: str, message_type, wait_for: int = 1):
        """A reliable publisher on ``topic``; waits until ``wait_for`` subscribers matched."""
        with self._lock:
            publisher = self.node.create_publisher(message_type, topic, TEST_QOS)
        if wait_for:
            matched = wait_until(
                lambda: publisher.get_subscription_count() >= wait_for, DISCOVERY_TIMEOUT
            )
            assert matched, f'no subscriber on {topic} after {DISCOVERY_TIMEOUT} s'
        return publisher

    def topics(self) -> dict[str, list[str]]:
        """Every topic seen on the graph and its types."""
        return dict(self.node.get_topic_names_and_types())

    def subscribers(self, topic: str) -> list[str]:
        """Fully qualified names of the nodes subscribing ``topic`` (absolute name)."""
        infos = self.node.get_subscriptions_info_by_topic(topic)
        return [f'{i.node_namespace.rstrip("/")}/{i.node_name}' for i in infos]

    def services(self) -> dict[str, list[str]]:
        """Every service seen on the graph and its types."""
        return dict(self.node.get_service_names_and_types())

    # services and parameters

    def call(self, service: str, service_type, request, timeout: float = DISCOVERY_TIMEOUT):
        """Call ``service`` (absolute name) and return the response (AssertionError on timeout).

        A server that has not yet matched a new client's reader drops its answer (rmw_fastrtps
        waits 100 ms for it, which a loaded machine exceeds), and every call makes a new client.
        So a request of a `REPEATABLE` type is sent again after 1 s without an answer. Any other
        is sent once, after the node that serves it has answered a harmless question on a client
        made after ours: Fast DDS announces our readers in creation order, so that node has then
        matched the reader of our answer (as the testing kit does).
        """
        with self._lock:
            client = self.node.create_client(service_type, service)
        try:
            assert client.wait_for_service(timeout_sec=timeout), f'{service} not available'
            if service_type in REPEATABLE:
                return self._answer(RepeatedCall(client, request).answer, service, timeout)
            self._warm_up(service, timeout)
            future = client.call_async(request)
            return self._answer(
                lambda: future.result() if future.done() else None, service, timeout
            )
        finally:
            with self._lock:
                self.node.destroy_client(client)

    def _warm_up(self, service: str, timeout: float) -> None:
        """Have the node serving ``service`` answer the session protocol's handshake."""
        server = wait_until(lambda: self._server_of(service), timeout)
        assert server, f'no node serves {service}'
        with self._lock:
            handshake = Handshake(self.node, [server])
        try:
            assert wait_until(lambda: not handshake.silent(), timeout), f'{server} is silent'
        finally:
            with self._lock:
                handshake.destroy()

    def _server_of(self, service: str) -> str | None:
        """Fully qualified name of the node that offers ``service``, or None."""
        for name, namespace in self.node.get_node_names_and_namespaces():
            with contextlib.suppress(NodeNameNonExistentError):  # it left meanwhile
                offered = self.node.get_service_names_and_types_by_node(name, namespace)
                if any(offered_name == service for offered_name, _ in offered):
                    return f'{namespace.rstrip("/")}/{name}'
        return None

    @staticmethod
    def _answer(answer: Callable[[], Any], service: str, timeout: float):
        """Wait for ``answer()`` to give a response (not None) and return it."""

        def answered():  # a one-tuple: wait_until stops on a truthy value
            response = answer()
            return None if response is None else (response,)

        got = wait_until(answered, timeout)
        assert got, f'{service} did not answer in {timeout} s'
        return got[0]

    def set_parameters(self, node: str, values: Mapping[str, Any]):
        """Set parameters of ``node`` (fully qualified name) one by one; list of results.

        Values may be any Python value: wrong types are sent as such (tests use that).
        """
        request = SetParameters.Request()
        request.parameters = [
            Parameter(
                name, value=list(value) if isinstance(value, tuple) else value
            ).to_parameter_msg()
            for name, value in values.items()
        ]
        return self.call(f'{node}/set_parameters', SetParameters, request).results

    def get_parameters(self, node: str, names: list[str]) -> list[Any]:
        """Current values of parameters of ``node`` (fully qualified name), as Python values."""
        request = GetParameters.Request(names=list(names))
        response = self.call(f'{node}/get_parameters', GetParameters, request)
        return [parameter_value_to_python(value) for value in response.values]

    @contextlib.contextmanager
    def parameters_restored(self, node: str, names: list[str]):
        """Within the block ``node``'s parameters ``names`` may change; then they are put back.

        For a node that a test module shares: what one test sets, the next does not inherit.
        An AssertionError after the block if ``node`` refuses its own old values.
        """
        before = dict(zip(names, self.get_parameters(node, names), strict=True))
        try:
            yield before
        finally:
            results = self.set_parameters(node, before)
        refused = [(n, r.reason) for n, r in zip(before, results, strict=True) if not r.successful]
        assert not refused, f'{node} refused its own parameters back: {refused}'
