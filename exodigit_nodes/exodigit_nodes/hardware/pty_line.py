"""The emulated board's line: bytes delayed, dropped or corrupted, on a pseudo-terminal.

:class:`ByteLine` is one direction of the line (a one-way latency, and each byte dropped or
corrupted with a probability); :class:`PseudoTerminal` the pty whose slave the host opens
through a fixed symbolic link, and which can be unplugged and plugged again. Both serve
``mcu_emulator`` (:mod:`.emulator`).
"""

from __future__ import annotations

import heapq
import math
import os
import tty

import numpy as np

from .emulated_board import EmulatorSettings


class ByteLine:
    """One direction of the line: bytes delayed by ``latency``, some dropped or corrupted."""

    def __init__(self, settings: EmulatorSettings, rng: np.random.Generator) -> None:
        self.settings = settings
        self.rng = rng
        self._queue: list[tuple[float, int, bytes]] = []
        self._count = 0
        self.dropped = 0
        self.corrupted = 0

    def put(self, data: bytes, now: float) -> None:
        """Bytes that enter the line at ``now``."""
        if not data:
            return
        settings = self.settings
        if settings.drop_probability or settings.corrupt_probability:
            data = self._damaged(data)
        self._count += 1
        heapq.heappush(self._queue, (now + settings.latency, self._count, data))

    def _damaged(self, data: bytes) -> bytes:
        draws = self.rng.random((2, len(data)))
        kept = bytearray()
        for byte, drop, corrupt in zip(data, draws[0], draws[1], strict=True):
            if drop < self.settings.drop_probability:
                self.dropped += 1
                continue
            if corrupt < self.settings.corrupt_probability:
                byte ^= 1 << int(self.rng.integers(8))
                self.corrupted += 1
            kept.append(byte)
        return bytes(kept)

    def due(self) -> float:
        """When the next bytes leave, s (inf if none wait)."""
        return self._queue[0][0] if self._queue else math.inf

    def take(self, now: float) -> bytes:
        """The bytes that have left the line by ``now``."""
        out = bytearray()
        while self._queue and self._queue[0][0] <= now:
            out += heapq.heappop(self._queue)[2]
        return bytes(out)

    def clear(self) -> None:
        """Lose every byte in flight (the cable is out)."""
        self._queue.clear()


class PseudoTerminal:
    """A pty whose slave is reached through the symbolic link ``link``; unplug and plug it."""

    def __init__(self, link: str) -> None:
        self.link = link
        self.master: int | None = None
        self._slave: int | None = None
        self.unwritten = 0
        """Bytes dropped because nobody read the slave and its buffer was full."""
        self.plug()

    @property
    def plugged(self) -> bool:
        return self.master is not None

    def plug(self) -> None:
        """A new pty, the link pointing at its slave."""
        if self.plugged:
            return
        master, slave = os.openpty()
        tty.setraw(slave)  # no echo, no line editing: bytes as they are
        os.set_blocking(master, False)
        self.master, self._slave = master, slave
        self._remove_link()
        os.symlink(os.ttyname(slave), self.link)

    def unplug(self) -> None:
        """Close the pty (the host's reads fail) and remove the link."""
        if not self.plugged:
            return
        self._remove_link()
        for fd in (self.master, self._slave):
            os.close(fd)
        self.master = self._slave = None

    def read(self) -> bytes:
        """What the host wrote (b'' if nothing, or unplugged)."""
        if self.master is None:
            return b''
        try:
            return os.read(self.master, 4096)
        except (BlockingIOError, OSError):
            return b''

    def write(self, data: bytes) -> None:
        """Send ``data`` to the host as far as the pty takes it (the rest is dropped)."""
        if self.master is None or not data:
            return
        try:
            written = os.write(self.master, data)
        except (BlockingIOError, OSError):
            written = 0
        self.unwritten += len(data) - written

    def close(self) -> None:
        self.unplug()

    def _remove_link(self) -> None:
        if os.path.islink(self.link):
            os.unlink(self.link)
