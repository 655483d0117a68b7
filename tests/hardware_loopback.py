"""A board in the test's own process behind a port object, on the test's clock (no pty).

:class:`LoopbackPort` is what :class:`exodigit_nodes.hardware.link.HostLink` opens: what the
host writes goes to a :class:`~exodigit_nodes.hardware.board.BoardProtocol` at the test's
current time, and what the board answers (and the samples the test makes it send) waits in the
port to be read. The test moves the clock (``port.now``) and can unplug the port.
"""

from __future__ import annotations

from exodigit_nodes.hardware.board import BoardProtocol, default_capabilities
from exodigit_nodes.hardware.port import PortError


class LoopbackPort:
    """An open port to an in-process board; ``opener`` gives it to a HostLink."""

    def __init__(self, board: BoardProtocol | None = None) -> None:
        self.board = board or BoardProtocol(default_capabilities())
        self.now = 0.0
        self.inbox = bytearray()
        self.written = bytearray()
        self.plugged = True
        self.opened = 0

    def opener(self, name: str, baud_rate: int) -> LoopbackPort:
        if not self.plugged:
            raise PortError(f'cannot open {name}: no such device')
        self.opened += 1
        return self

    def fileno(self) -> None:
        return None

    def read(self) -> bytes:
        if not self.plugged:
            raise PortError('device disconnected')
        data, self.inbox = bytes(self.inbox), bytearray()
        return data

    def write(self, data: bytes) -> None:
        if not self.plugged:
            raise PortError('device disconnected')
        self.written += data
        self.inbox += self.board.receive(data, self.now)

    def discard_input(self) -> None:
        self.inbox.clear()

    def close(self) -> None:
        pass

    def sample(self, pressures=(0, 0, 0), angles=(0, 0, 0)) -> None:
        """The board samples now (nothing before a Hello)."""
        self.board.duties(self.now)
        self.inbox += self.board.sample(self.now, tuple(pressures), tuple(angles))
