"""The three nodes started in every order (6 orders) give the same, normal glove.

The orders run side by side, one namespace each (``/order0`` .. ``/order5``), their 18 nodes
in one host process (tests/node_host.py: one start-up instead of 18, each node built when the
test asks), at a low rate: in three waves, each order starts its next node, and the next wave
begins once the probe has discovered every node of the wave (the publisher of its first output,
that node's, on the graph), so each node's endpoints are announced before the next node of its
order starts. Then the probe subscribes (not before: what the gloves send while they start is
no use to the check, and would only cost CPU) and every glove must be normal
(`reliability_session.GloveSession.normal`: commands reach the chambers, the state is the
model's solve, the estimator agrees with the plant and identifies K_H, and every node reports
in /diagnostics).
"""

import itertools
import time

import pytest
from diagnostic_msgs.msg import DiagnosticArray
from node_host import NodeHost
from reliability_session import NODES, START_TIMEOUT, GloveSession
from ros_harness import wait_until

ORDERS = list(itertools.permutations(NODES))
#: Node rate in this test, Hz (every message costs the host and the probe CPU; the checks need
#: few of them), and the estimator window (pairs; its least): one second. The
#: estimator fits what part of its window it holds, so a longer window delays nothing.
RATE = 10.0
WINDOW = 10
OVERRIDES = {
    'plant': {'rate_hz': RATE},
    'pressure_command': {'rate_hz': RATE},
    'estimator': {'identification_window': WINDOW},
}
#: A topic each node publishes from its constructor on, whatever its inputs.
FIRST_OUTPUT = {
    'plant': 'joint_states',
    'pressure_command': 'pressure_command',
    'estimator': 'estimated_contact_forces',
}


def discovered(session: GloveSession, node: str) -> bool:
    """Wait until the probe has discovered ``node``'s publisher (its first start only)."""
    return bool(wait_until(lambda: session.publishes(node, FIRST_OUTPUT[node]), START_TIMEOUT))


@pytest.fixture
def host(ros_domain, tmp_path):
    nodes = NodeHost(ros_domain, tmp_path)
    yield nodes
    assert nodes.close() == 0, nodes.log()


def test_every_start_order_gives_a_normal_glove(host, probe):
    sessions = [
        GloveSession(host, probe, f'/order{i}', OVERRIDES, listen=False)
        for i in range(len(ORDERS))
    ]
    for wave in range(len(NODES)):
        for session, order in zip(sessions, ORDERS, strict=True):
            session.start(order[wave])
        for session, order in zip(sessions, ORDERS, strict=True):
            assert discovered(session, order[wave]), f'order {order}: {order[wave]} not found'
    diagnostics = probe.subscribe('/diagnostics', DiagnosticArray)
    for session in sessions:
        session.listen(diagnostics)
    listening = time.monotonic()
    results = {o: s.normal(since=listening) for o, s in zip(ORDERS, sessions, strict=True)}
    assert all(problems == [] for problems in results.values()), results
