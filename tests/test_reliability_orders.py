"""The three nodes started in every order (6 orders) give the same, normal glove.

The orders run side by side, one namespace each (``/order0`` .. ``/order5``), at a low rate so
that 18 processes fit on two cores: in three waves, each order starts its next node, and the
next wave begins once the probe has discovered every node of the wave (matched the publisher of
its first output), so each node's endpoints are announced before the next node of its order
starts. Then every glove must be normal (`reliability_session.GloveSession.normal`: commands
reach the chambers, the state is the model's solve, the estimator agrees with the plant and
identifies K_H, and every node reports in /diagnostics).
"""

import itertools
import time

from reliability_session import NODES, START_TIMEOUT, GloveSession
from ros_harness import wait_until

ORDERS = list(itertools.permutations(NODES))
#: Node rate in this test, Hz (every message costs the 18 processes and the probe CPU; the
#: checks need few of them), and the estimator window (pairs; its least): one second. The
#: estimator fits what part of its window it holds, so a longer window delays nothing.
RATE = 10.0
WINDOW = 10
#: Diagnostics period, s: "every node reports" counts reports since the first wave began, so
#: the default period is short enough (the waves take seconds), and a shorter one only adds
#: the probe 18 reports more to take in per period.
REPORT_PERIOD = 1.0
OVERRIDES = {
    'plant': {'rate_hz': RATE, 'diagnostic_period': REPORT_PERIOD},
    'pressure_command': {'rate_hz': RATE, 'diagnostic_period': REPORT_PERIOD},
    'estimator': {'identification_window': WINDOW, 'diagnostic_period': REPORT_PERIOD},
}
#: A topic each node publishes from its constructor on, whatever its inputs.
FIRST_OUTPUT = {
    'plant': 'joint_states',
    'pressure_command': 'pressure_command',
    'estimator': 'estimated_contact_forces',
}


def discovered(session: GloveSession, node: str) -> bool:
    """Wait until the probe has matched ``node``'s publisher (its first start only)."""
    inbox = session.inbox[FIRST_OUTPUT[node]]
    return bool(wait_until(lambda: inbox.matched() >= 1, START_TIMEOUT))


def test_every_start_order_gives_a_normal_glove(launcher, probe):
    sessions = [GloveSession(launcher, probe, f'/order{i}', OVERRIDES) for i in range(len(ORDERS))]
    began = time.monotonic()
    for wave in range(len(NODES)):
        for session, order in zip(sessions, ORDERS, strict=True):
            session.start(order[wave])
        for session, order in zip(sessions, ORDERS, strict=True):
            assert discovered(session, order[wave]), f'order {order}: {order[wave]} not found'
    results = {order: s.normal(since=began) for order, s in zip(ORDERS, sessions, strict=True)}
    assert all(problems == [] for problems in results.values()), results
