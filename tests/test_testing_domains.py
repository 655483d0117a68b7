"""The testing kit's free ROS domains (domain_coordinator): held across processes, never 37."""

import contextlib
import subprocess
import sys

import pytest
from exodigit_nodes.testing import processes
from exodigit_nodes.testing.processes import DOMAIN_IDS, claim_domain

#: Claims one of the ids given and prints it, or prints the error.
CLAIM = """
import sys
from exodigit_nodes.testing.processes import claim_domain
try:
    lease = claim_domain([int(i) for i in sys.argv[1:]])
except RuntimeError as error:
    print('refused', error)
else:
    print('claimed', lease.domain_id)
"""


def claim_elsewhere(*ids: int) -> str:
    """What another process gets when it claims one of ``ids``."""
    done = subprocess.run(
        [sys.executable, '-c', CLAIM, *map(str, ids)],
        capture_output=True,
        text=True,
        timeout=60,
        check=True,
    )
    return done.stdout.strip()


def test_a_held_domain_is_refused_to_another_process_until_released():
    lease = claim_domain()
    held = lease.domain_id
    try:
        assert held in DOMAIN_IDS
        assert (
            claim_elsewhere(held)
            == f'refused every test ROS domain id in {held}..{held} is in use'
        )
    finally:
        lease.release()
    lease.release()  # twice changes nothing
    assert claim_elsewhere(held) == f'claimed {held}'


def test_two_leases_of_one_process_never_share_an_id():
    first = claim_domain()
    try:
        second = claim_domain()
        assert second.domain_id != first.domain_id
        second.release()
    finally:
        first.release()


def test_the_make_run_domain_is_never_offered(monkeypatch):
    offered = []

    @contextlib.contextmanager
    def coordinator(selector):
        # as domain_coordinator: up to 100 offers, the first whose port is free is held
        offered.extend(selector() for _ in range(300))
        yield offered[-1]

    monkeypatch.setattr(processes, 'domain_id', coordinator)
    claim_domain().release()
    assert 37 not in offered
    assert set(offered) == set(range(1, 101)) - {37}


def test_no_free_id_is_one_line_naming_the_range(monkeypatch):
    @contextlib.contextmanager
    def coordinator(selector):
        raise RuntimeError('Failed to get a unique ROS domain ID')
        yield

    monkeypatch.setattr(processes, 'domain_id', coordinator)
    with pytest.raises(RuntimeError, match=r'every test ROS domain id in 1\.\.100 is in use'):
        claim_domain()
