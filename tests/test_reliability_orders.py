"""The three nodes started in every order (6 orders) give the same, normal glove.

The orders run side by side, one namespace each (``/order0`` .. ``/order5``), at a low rate so
that 18 processes fit on two cores: in three waves, each order starts its next node, and the
next wave begins once every node of the wave has reported in /diagnostics. Then every glove
must be normal (`reliability_session.GloveSession.normal`: commands reach the chambers, the
state is the model's solve, the estimator agrees with the plant and identifies K_H).
"""

import itertools
import time

from reliability_session import NODES, GloveSession

ORDERS = list(itertools.permutations(NODES))
#: Node rate in this test, Hz, and the estimator window at that rate (pairs).
RATE = 20.0
WINDOW = 20
OVERRIDES = {
    'plant': {'rate_hz': RATE},
    'pressure_command': {'rate_hz': RATE},
    'estimator': {'identification_window': WINDOW},
}


def test_every_start_order_gives_a_normal_glove(launcher, probe):
    sessions = [GloveSession(launcher, probe, f'/order{i}', OVERRIDES) for i in range(len(ORDERS))]
    began = time.monotonic()
    for wave in range(len(NODES)):
        started = time.monotonic()
        for session, order in zip(sessions, ORDERS, strict=True):
            session.start(order[wave])
        for session, order in zip(sessions, ORDERS, strict=True):
            assert session.reported(order[wave], started), f'order {order}: {order[wave]} silent'
    results = {order: s.normal(since=began) for order, s in zip(ORDERS, sessions, strict=True)}
    assert all(problems == [] for problems in results.values()), results
