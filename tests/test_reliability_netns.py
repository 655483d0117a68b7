"""The two-host helper: isolated namespaces, a link that really cuts, nothing left behind."""

import subprocess
import sys

import pytest
from reliability_netns import NetnsPair, netns_pair

#: A UDP echo inside the pair: side 1 echoes once; side 0 sends every 0.1 s (the server may not be
#: bound yet) until an echo comes back or its time is up, and prints what it got.
ECHO = """
import socket, sys, time
role, address = sys.argv[1], sys.argv[2]
s = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
if role == 'server':
    s.bind((address, 47000))
    data, peer = s.recvfrom(64)
    s.sendto(data, peer)
    sys.exit()
s.settimeout(0.1)
end, got = time.monotonic() + float(sys.argv[3]), 'nothing'
while time.monotonic() < end and got != 'ping':
    try:
        s.sendto(b'ping', (address, 47000))
        got = s.recvfrom(64)[0].decode()
    except OSError as error:
        got = type(error).__name__
print(got)
"""


@pytest.fixture
def pair():
    with netns_pair() as made:
        yield made


def echo(pair: NetnsPair, timeout: float) -> str:
    server = pair.popen(1, [sys.executable, '-c', ECHO, 'server', pair.addresses[1], '0'])
    try:
        client = subprocess.run(
            ['ip', 'netns', 'exec', pair.names[0], sys.executable, '-c', ECHO, 'client',
             pair.addresses[1], str(timeout)],
            capture_output=True, text=True, timeout=30, check=True,
        )  # fmt: skip
    finally:
        server.kill()
        server.wait()
    return client.stdout.strip()


def interfaces(name: str) -> set[str]:
    out = subprocess.run(
        ['ip', '-n', name, '-o', 'link', 'show'], capture_output=True, text=True, check=True
    ).stdout
    return {line.split(':')[1].strip().split('@')[0] for line in out.splitlines()}


def test_namespaces_see_only_loopback_and_their_end_of_the_link(pair):
    for name, veth in zip(pair.names, pair.veths, strict=True):
        assert interfaces(name) == {'lo', veth}


def test_link_carries_traffic_stops_when_cut_and_carries_again_when_restored(pair):
    assert echo(pair, timeout=5.0) == 'ping'
    pair.cut()
    assert echo(pair, timeout=0.5) != 'ping'
    pair.restore()
    assert echo(pair, timeout=5.0) == 'ping'


def test_close_removes_both_namespaces_and_their_processes(pair):
    sleeper = pair.popen(0, ['sleep', '60'])
    pair.close()
    assert sleeper.wait(timeout=5) != 0
    listed = subprocess.run(['ip', 'netns', 'list'], capture_output=True, text=True).stdout
    assert not set(pair.names) & {line.split()[0] for line in listed.splitlines() if line}
