"""An emulated board served by a thread of the test's own process, on a real pty.

Cheaper than ``mcu_emulator`` as a process (:class:`exodigit_nodes.testing.EmulatorProcess`):
no interpreter to start, and the model's compiled kernels load once per test process, not once
per board. Fault commands go through a pipe, as they go to the program's standard input.
"""

from __future__ import annotations

import os
import threading

from exodigit_nodes.hardware.emulated_board import EmulatorSettings
from exodigit_nodes.hardware.emulator import BoardStatus, Emulator


class RunningEmulator:
    """An :class:`Emulator` serving at ``<directory>/board`` for ``duration`` s at most."""

    def __init__(self, directory, duration: float = 30.0, **settings) -> None:
        self.link = str(directory / 'board')
        self.emulator = Emulator(EmulatorSettings(**settings), self.link)
        read, self._write = os.pipe()
        self._commands = os.fdopen(read)
        self.thread = threading.Thread(
            target=self.emulator.run, args=(duration, self._commands), daemon=True
        )
        self.thread.start()

    def command(self, line: str) -> None:
        """A fault command (``unplug 1.5``...), taken by the serving thread at its next turn."""
        os.write(self._write, (line + '\n').encode())

    def status(self) -> BoardStatus:
        """What the board does now."""
        return self.emulator.status()

    def stop(self) -> None:
        self.command('quit')
        self.thread.join(10.0)
        assert not self.thread.is_alive()
        self.emulator.close()
        os.close(self._write)
        self._commands.close()
