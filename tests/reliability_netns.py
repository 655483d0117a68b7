"""Two private network namespaces joined by a veth pair: two "hosts" on one machine.

As root with iproute2, `NetnsPair.create` makes namespaces ``<tag>-a`` and ``<tag>-b``, each with
``lo`` up and one end of a veth pair carrying a 10.x address that exists only inside them. ROS
processes run inside with `NetnsPair.popen`; their discovery is open (``SUBNET``) but the only
interfaces they see are ``lo`` and the veth, so every packet stays on this machine. Fast DDS's
shared-memory transport is switched off (``FASTDDS_BUILTIN_TRANSPORTS=UDPv4``): two processes on
one kernel would otherwise talk through /dev/shm and a cut link would cut nothing.

`NetnsPair.cut` and `NetnsPair.restore` take the link down and up; `NetnsPair.close` kills what
still runs inside and deletes both namespaces (the veth goes with them). `netns_pair` is the
context manager behind the tests' fixtures; it skips, with the reason, where namespaces
cannot be made.
"""

import contextlib
import os
import shutil
import signal
import subprocess
from collections.abc import Iterator, Mapping, Sequence
from dataclasses import dataclass, field

import pytest

#: Multicast range Fast DDS announces on; routed to the veth so SPDP reaches the peer.
MULTICAST_RANGE = '224.0.0.0/4'
#: Prefix length of the two-address link.
PREFIX = 30
#: Seconds an iproute2 command may take.
IP_TIMEOUT = 10.0


class NetnsUnavailableError(RuntimeError):
    """Namespaces cannot be made here (not root, no iproute2, no permission)."""


def _ip(*args: str) -> None:
    result = subprocess.run(
        ['ip', *args], capture_output=True, text=True, timeout=IP_TIMEOUT, check=False
    )
    if result.returncode != 0:
        raise NetnsUnavailableError(f'ip {" ".join(args)}: {result.stderr.strip()}')


@dataclass
class NetnsPair:
    """Namespaces ``names[0]`` (address ``addresses[0]``) and ``names[1]`` joined by a veth.

    Attributes
    ----------
    names : tuple of str
        The two namespace names.
    addresses : tuple of str
        Each namespace's veth address (no prefix length).
    veths : tuple of str
        Each namespace's veth interface name.
    """

    names: tuple[str, str]
    addresses: tuple[str, str]
    veths: tuple[str, str]
    started: list[subprocess.Popen] = field(default_factory=list)
    """What :meth:`popen` started (a process may not have entered its namespace yet)."""

    @classmethod
    def create(cls, tag: str, subnet: int) -> 'NetnsPair':
        """Make the pair; ``subnet`` (0-255) picks 10.213.<subnet>.1 and .2.

        Raises
        ------
        NetnsUnavailableError
            With the reason, when this machine cannot make namespaces.
        """
        if os.geteuid() != 0:
            raise NetnsUnavailableError('network namespaces need root')
        if shutil.which('ip') is None:
            raise NetnsUnavailableError('iproute2 (the ip command) is not installed')
        pair = cls(
            names=(f'{tag}-a', f'{tag}-b'),
            addresses=(f'10.213.{subnet}.1', f'10.213.{subnet}.2'),
            veths=(f'{tag[:10]}a', f'{tag[:10]}b'),
        )
        try:
            pair._build()
        except BaseException:
            pair.close()
            raise
        return pair

    def _build(self) -> None:
        for name in self.names:
            _ip('netns', 'add', name)
            _ip('-n', name, 'link', 'set', 'lo', 'up')
        _ip(
            '-n', self.names[0], 'link', 'add', self.veths[0], 'type', 'veth',
            'peer', 'name', self.veths[1], 'netns', self.names[1],
        )  # fmt: skip
        for name, veth, address in zip(self.names, self.veths, self.addresses, strict=True):
            _ip('-n', name, 'addr', 'add', f'{address}/{PREFIX}', 'dev', veth)
        self.restore()

    def restore(self) -> None:
        """Bring the link up (again) with its multicast route."""
        for name, veth in zip(self.names, self.veths, strict=True):
            _ip('-n', name, 'link', 'set', veth, 'up')
            _ip('-n', name, 'route', 'replace', MULTICAST_RANGE, 'dev', veth)

    def cut(self) -> None:
        """Take both ends of the link down: nothing passes between the namespaces."""
        for name, veth in zip(self.names, self.veths, strict=True):
            _ip('-n', name, 'link', 'set', veth, 'down')

    def environment(self, base: Mapping[str, str], domain_id: int, side: int) -> dict[str, str]:
        """Environment for a ROS process in namespace ``side`` (0 or 1).

        Discovery is ``SUBNET`` with the peer's address as a static peer; inside the namespace that
        subnet is the veth and nothing else.
        """
        env = dict(base)
        env['ROS_AUTOMATIC_DISCOVERY_RANGE'] = 'SUBNET'
        env['ROS_STATIC_PEERS'] = self.addresses[1 - side]
        env['ROS_DOMAIN_ID'] = str(domain_id)
        env['FASTDDS_BUILTIN_TRANSPORTS'] = 'UDPv4'
        return env

    def popen(self, side: int, argv: Sequence[str], **kwargs) -> subprocess.Popen:
        """Start ``argv`` inside namespace ``side`` (in its own session, for group signals)."""
        process = subprocess.Popen(
            ['ip', 'netns', 'exec', self.names[side], *argv], start_new_session=True, **kwargs
        )
        self.started.append(process)
        return process

    def pids(self) -> list[int]:
        """Processes still running inside either namespace."""
        found = []
        for name in self.names:
            result = subprocess.run(
                ['ip', 'netns', 'pids', name],
                capture_output=True,
                text=True,
                timeout=IP_TIMEOUT,
                check=False,
            )
            found += [int(pid) for pid in result.stdout.split()]
        return found

    def close(self) -> None:
        """Kill whatever still runs inside, then delete both namespaces (and the veth).

        What :meth:`popen` started is killed by its process group too: one that has not entered
        its namespace yet is not among :meth:`pids` (a CI run's sleeper outlived the close).
        """
        for process in self.started:
            if process.poll() is None:
                with contextlib.suppress(ProcessLookupError):
                    os.killpg(process.pid, signal.SIGKILL)
        for pid in self.pids():
            with contextlib.suppress(ProcessLookupError):
                os.kill(pid, signal.SIGKILL)
        for name in self.names:
            subprocess.run(
                ['ip', 'netns', 'delete', name],
                capture_output=True,
                timeout=IP_TIMEOUT,
                check=False,
            )


@contextlib.contextmanager
def netns_pair() -> Iterator[NetnsPair]:
    """A fresh `NetnsPair`, always deleted on exit; skips the calling test where impossible.

    Tests wrap it in a fixture: ``with netns_pair() as pair: yield pair``.
    """
    tag = f'exo{os.getpid() % 100000}'
    try:
        pair = NetnsPair.create(tag, subnet=os.getpid() % 256)
    except NetnsUnavailableError as error:
        pytest.skip(f'two-host test needs network namespaces: {error}')
    try:
        yield pair
    finally:
        pair.close()
