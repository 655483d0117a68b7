"""The glove on an emulated board, for a controller's tests without a board (docs/hardware.md).

:class:`EmulatedGlove` runs ``mcu_emulator`` (the simulated glove behind an emulated board, on a
pseudo-terminal) and the ``hardware`` bridge on it, in a private ROS domain and a fresh
namespace: a controller of yours started with :attr:`EmulatedGlove.env` in
:attr:`EmulatedGlove.namespace` drives the board exactly as it would drive a real one
(``valve_command`` in; ``chamber_pressure``, ``joint_states``, ``applied_command`` and
``/diagnostics`` out), on the wall clock. The test reads what the board does without ROS
(:meth:`EmulatedGlove.status`, :meth:`EmulatedGlove.wait_for`) and can make it fail
(:meth:`EmulatedGlove.fault`: unplug, supply loss, a stuck valve). The pytest plugin gives it as
the ``emulated_glove`` fixture. :class:`EmulatorProcess` is the emulator alone.

Unlike :class:`.client.GloveSim` (lockstep simulated time, exact and repeatable) this is the
real-time path a real board takes: serial link, board watchdog, the bridge's safety rules.
"""

from __future__ import annotations

import contextlib
import os
import queue
import subprocess
import sys
import threading
import time
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path
from typing import Any

from ..hardware.emulator import BoardStatus
from ..runner.supervisor import STOP_GRACE, Child, Exit
from .processes import KitPlace, NodeProcess

START_TIMEOUT = 60.0
"""Longest wait for the emulator to serve and the bridge to start a session with it, s."""
POLL = 0.05
"""How often :meth:`EmulatedGlove.wait_for` asks the board, s."""


class EmulatorError(RuntimeError):
    """The emulated board did not start or answer; the text says what and where its log is."""


class EmulatorProcess(Child):
    """``mcu_emulator`` as a process: fault commands to its standard input, answers read back.

    Parameters
    ----------
    link : str or Path
        Where its pseudo-terminal appears (a symbolic link: the bridge's ``port``).
    log_dir : str or Path
        Where its stderr goes (``mcu_emulator.log``).
    arguments : sequence of str
        More ``mcu_emulator`` options (``--latency 0.01``, ``--no-bend-sensors``...).
    timeout : float
        Longest wait for it to serve, s.

    Raises
    ------
    EmulatorError
        If it does not serve within ``timeout`` (it refused an option, say).
    """

    def __init__(
        self,
        link: str | os.PathLike,
        log_dir: str | os.PathLike,
        arguments: Sequence[str] = (),
        timeout: float = START_TIMEOUT,
    ) -> None:
        self.link = str(link)
        command = [sys.executable, '-m', 'exodigit_nodes.hardware.emulator', '--link', self.link]
        log = Path(log_dir) / 'mcu_emulator.log'
        super().__init__(
            'mcu_emulator', [*command, *arguments], os.environ, log, pipes=True, defer_sigint=True
        )
        self.lines: queue.Queue[str] = queue.Queue()
        threading.Thread(target=self._read, daemon=True).start()
        if self.answer('mcu_emulator: board', timeout) is None:
            self.stop()
            raise EmulatorError(f'mcu_emulator did not serve on {self.link}: see {log}')

    def _read(self) -> None:
        for line in self.popen.stdout:
            self.lines.put(line.decode(errors='replace').rstrip('\n'))

    def answer(self, start: str, timeout: float = 5.0) -> str | None:
        """The next line it prints that starts with ``start`` (None after ``timeout`` s)."""
        end = time.monotonic() + timeout
        while (left := end - time.monotonic()) > 0:
            try:
                line = self.lines.get(timeout=left)
            except queue.Empty:
                return None
            if line.startswith(start):
                return line
        return None

    def command(self, line: str) -> None:
        """Send one fault command (``unplug 1.5``, ``supply off``...: ``mcu_emulator --help``)."""
        if not self.alive():
            raise EmulatorError(f'mcu_emulator has ended ({self.exit().describe()})')
        self.popen.stdin.write(line.encode() + b'\n')
        self.popen.stdin.flush()

    def status(self, timeout: float = 5.0) -> BoardStatus:
        """What the board does now (``status``)."""
        self.command('status')
        line = self.answer('status ', timeout)
        if line is None:
            raise EmulatorError(f'mcu_emulator did not answer status within {timeout:g} s')
        return BoardStatus.parse(line)

    def stop(self, grace: float = STOP_GRACE, idle=None) -> Exit:
        """``quit``, then the stop escalation of :class:`Child` if it does not end."""
        if self.alive():
            with contextlib.suppress(OSError, EmulatorError, subprocess.TimeoutExpired):
                self.command('quit')
                self.popen.wait(grace)
        return super().stop(grace, idle)


class EmulatedGlove:
    """The glove on an emulated board behind the ``hardware`` bridge, for a controller's test.

    Parameters
    ----------
    emulator : sequence of str
        More ``mcu_emulator`` options: its line (``--latency``, ``--drop-probability``...), its
        sensors, its model (``--params-file``).
    bridge : mapping, optional
        More parameters of the ``hardware`` node (``max_pressure``, ``command_timeout``...).
    namespace, domain_id, log_dir
        As for :class:`.client.GloveSim`: a fresh namespace, a free domain and a temporary
        folder when omitted.
    timeout : float
        Longest wait for the board and the bridge to start, s.

    Attributes
    ----------
    namespace : str
        Where the bridge's topics are: start your controller there.
    env : dict
        The environment for your controller's process (the domain, loopback-only discovery).
    board : EmulatorProcess
    bridge : NodeProcess

    Examples
    --------
    >>> with EmulatedGlove() as glove:                       # doctest: +SKIP
    ...     controller = subprocess.Popen(
    ...         ['my_controller', '--ros-args', '-r', f'__ns:={glove.namespace}'], env=glove.env
    ...     )
    ...     status = glove.wait_for(lambda board: board.pressures[0] > 20e3, timeout=30.0)
    """

    def __init__(
        self,
        emulator: Sequence[str] = (),
        bridge: Mapping[str, Any] | None = None,
        *,
        namespace: str | None = None,
        domain_id: int | None = None,
        log_dir: str | os.PathLike | None = None,
        timeout: float = START_TIMEOUT,
    ) -> None:
        self._place = KitPlace('emulated_glove', namespace, domain_id, log_dir)
        self.namespace = self._place.namespace
        self.domain_id = self._place.domain_id
        self.env = self._place.env
        self.log_dir = self._place.log_dir
        self.board: EmulatorProcess | None = None
        self.bridge: NodeProcess | None = None
        try:
            self.board = EmulatorProcess(self.log_dir / 'board', self.log_dir, emulator, timeout)
            self.bridge = NodeProcess(
                'hardware',
                {'port': self.board.link, **(bridge or {})},
                self.domain_id,
                self.log_dir,
                self.namespace,
            )
            if self.wait_for(lambda board: board.streaming, timeout) is None:
                raise EmulatorError(
                    f'the hardware bridge started no session with the board within {timeout:g} '
                    f's: see {self.bridge.stderr_path}'
                )
        except BaseException:
            self.close()
            raise

    def status(self) -> BoardStatus:
        """What the board does now: openings applied, pressures read, session and watchdog."""
        return self.board.status()

    def wait_for(
        self, condition: Callable[[BoardStatus], bool], timeout: float
    ) -> BoardStatus | None:
        """The first status of the board that meets ``condition`` (None after ``timeout`` s).

        Raises
        ------
        EmulatorError
            If the bridge or the board has ended meanwhile.
        """
        end = time.monotonic() + timeout
        while True:
            if not self.bridge.alive():
                raise EmulatorError(
                    f'the hardware bridge has ended: see {self.bridge.stderr_path}'
                )
            status = self.status()
            if condition(status):
                return status
            if time.monotonic() >= end:
                return None
            time.sleep(POLL)

    def fault(self, line: str) -> None:
        """A fault of the board or its cable (``mcu_emulator --help``).

        ``unplug [SECONDS]``, ``plug``, ``supply off|on``, ``stick VALVE OPENING``, ``unstick``.
        """
        self.board.command(line)

    def close(self) -> None:
        """Stop the bridge (it vents first), then the board; release the domain (idempotent)."""
        for process in (self.bridge, self.board):
            if process is not None:
                process.stop()
        self.bridge = self.board = None
        self._place.close()

    def __enter__(self) -> EmulatedGlove:
        return self

    def __exit__(self, *exc_info) -> None:
        self.close()
