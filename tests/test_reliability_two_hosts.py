"""Two hosts: the plant in one network namespace, controller and estimator in another.

The namespaces are joined by a veth pair (`reliability_netns`); discovery is open inside them
(``SUBNET`` plus the peer as a static peer) but they hold nothing but loopback and the veth, so
no packet leaves this machine, and shared memory is off so the link is the only way across.
A listener runs on each side (`reliability_netns_probe.py`). The glove must work across the
link (commands reach the plant, angles and pressures reach the estimator); cutting the link must
make the plant vent on its watchdog and say so; restoring it must bring the commands back.
Skips with the reason where namespaces cannot be made (not root, no iproute2).
"""

import json
import os
import subprocess
import sys
import threading
import time
from pathlib import Path

import pytest
from reliability_netns import netns_pair
from ros_harness import ros_args, wait_until

PROBE = str(Path(__file__).with_name('reliability_netns_probe.py'))
NAMESPACE = '/two_hosts'
HOLD = 20e3
#: A vented chamber holds less than this, Pa.
VENTED = 100.0
#: Discovery across the link and node start-up, s.
START_TIMEOUT = 45.0
#: Plant watchdog (its default) and the time the vent may take after it, s.
COMMAND_TIMEOUT = 0.5
VENT_TIMEOUT = COMMAND_TIMEOUT + 5.0
#: Reliable traffic resumes after the link returns within this, s (Fast DDS resends).
RESUME_TIMEOUT = 20.0
#: The plant's diagnostics period, s: the venting report is waited for (default 1 s).
REPORT_PERIOD = 0.2


class Lines:
    """JSON lines of a listener process, read by a thread, with arrival times."""

    def __init__(self, process) -> None:
        self.records: list[tuple[float, dict]] = []
        self._lock = threading.Lock()
        self._thread = threading.Thread(target=self._read, args=(process.stdout,), daemon=True)
        self._thread.start()

    def _read(self, stream) -> None:
        for line in stream:
            with self._lock:
                self.records.append((time.monotonic(), json.loads(line)))

    def find(self, predicate, since: float = -1.0):
        with self._lock:
            return next((r for t, r in self.records if t > since and predicate(r)), None)

    def wait(self, predicate, timeout: float, since: float = -1.0):
        return wait_until(lambda: self.find(predicate, since), timeout)


@pytest.fixture
def hosts():
    with netns_pair() as pair:
        yield pair


def start(pair, side: int, argv: list[str], domain: int, tmp_path: Path, label: str):
    env = pair.environment(os.environ, domain, side)
    env['PYTHONUNBUFFERED'] = '1'
    with open(tmp_path / f'{label}.err', 'w') as err:
        return pair.popen(
            side, argv, env=env, cwd=tmp_path, stdout=subprocess.PIPE,
            stderr=err, stdin=subprocess.DEVNULL, text=True,
        )  # fmt: skip


def node(module: str, parameters: dict) -> list[str]:
    command = [sys.executable, '-m', f'exodigit_nodes.nodes.{module}']
    return [*command, *ros_args(parameters, namespace=NAMESPACE)]


def is_pressure(low: float, high: float):
    def check(record: dict) -> bool:
        return record['topic'].endswith('chamber_pressure') and all(
            low <= v <= high for v in record['values']
        )

    return check


def test_glove_works_across_the_link_and_vents_when_it_is_cut(hosts, ros_domain, tmp_path):
    plant = start(
        hosts,
        0,
        node('plant', {'diagnostic_period': REPORT_PERIOD}),
        ros_domain,
        tmp_path,
        'plant',
    )
    plant_side = Lines(
        start(hosts, 0, [sys.executable, PROBE, f'{NAMESPACE}/chamber_pressure', '/diagnostics'],
              ros_domain, tmp_path, 'probe_a')
    )  # fmt: skip
    controller = start(
        hosts, 1, node('pressure_command', {'mode': 'hold', 'hold_pressure': [HOLD] * 3}),
        ros_domain, tmp_path, 'pressure_command',
    )  # fmt: skip
    estimator = start(hosts, 1, node('estimator', {}), ros_domain, tmp_path, 'estimator')
    controller_side = Lines(
        start(hosts, 1, [sys.executable, PROBE, f'{NAMESPACE}/estimated_contact_forces'],
              ros_domain, tmp_path, 'probe_b')
    )  # fmt: skip

    held = plant_side.wait(is_pressure(0.99 * HOLD, 1.01 * HOLD), START_TIMEOUT)
    assert held, f'commands never crossed the link ({(tmp_path / "plant.err").read_text()})'
    estimated = controller_side.wait(lambda r: True, START_TIMEOUT)
    assert estimated, 'plant state never reached the estimator across the link'

    cut = time.monotonic()
    hosts.cut()
    assert plant_side.wait(is_pressure(0.0, VENTED), VENT_TIMEOUT, since=cut), 'did not vent'

    def venting(record: dict) -> bool:
        return record.get('name') == f'{NAMESPACE}/plant' and (
            record['values'].get('watchdog') == 'venting'
        )

    assert plant_side.wait(venting, VENT_TIMEOUT, since=cut), 'venting not reported'

    restored = time.monotonic()
    hosts.restore()
    back = plant_side.wait(is_pressure(0.99 * HOLD, 1.01 * HOLD), RESUME_TIMEOUT, since=restored)
    assert back, 'commands did not come back after the link was restored'
    assert all(p.poll() is None for p in (plant, controller, estimator))
