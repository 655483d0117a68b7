"""``mcu_emulator``: an emulated glove board on a pseudo-terminal (docs/hardware.md).

The glove behind valves (``exodigit_model.GloveSimulation(actuation='valves')``,
docs/spec/model.md §14) stepped at the board's sample rate on the wall clock, behind the
board's side of the link (:class:`.board.BoardProtocol`), served on a pseudo-terminal whose
slave is reached through a fixed path (a symbolic link, ``--link``): open it as you would
``/dev/ttyACM0``. Each step applies the openings the board holds (a vent before a Hello, on
its watchdog and above its vent pressure), reads the sensors (the simulation's seeded noise,
then quantised to the sensor's resolution and clipped to its range) and sends one sample.

Line faults: a one-way latency, and each byte dropped or corrupted (one bit flipped) with a
probability, both ways. Board faults, typed on standard input while it runs (one a line):

- ``unplug [SECONDS]``: the USB cable out (the pty and the link vanish; the board loses power
  and vents); back after SECONDS, or at ``plug``;
- ``plug``: the cable back in (the board boots: silent and vented until a Hello);
- ``supply off|on``: the supply lost (no air comes through the inlets; the board flags it) or
  back;
- ``stick VALVE OPENING``: valve 0-5 (inlets MCP, PIP, DIP, then outlets) stays at OPENING in
  [0, 1] whatever is commanded; ``unstick`` frees them;
- ``status``: print one line: streaming or silent, the openings applied, the watchdog, the
  pressures read (:class:`BoardStatus`, which reads it back);
- ``quit``: stop.

Run: ``python -m exodigit_nodes.hardware.emulator --link /tmp/glove_board`` (``--help``).
"""

from __future__ import annotations

import argparse
import math
import os
import re
import select
import sys
import time
from dataclasses import dataclass

import numpy as np

from ..logic.lifetime import StopRequest
from .emulated_board import EmulatedBoard, EmulatorSettings
from .messages import CHAMBERS
from .pty_line import ByteLine, PseudoTerminal

STATUS_PATTERN = re.compile(
    r'status (?P<state>streaming|silent), openings (?P<openings>[^,]+), '
    r'watchdog (?P<watchdog>tripped|fed), pressures (?P<pressures>[^,]+) Pa'
)
"""The line :class:`BoardStatus` is written as."""


@dataclass(frozen=True)
class BoardStatus:
    """What the emulated board does now: the answer to ``status``, one line of text.

    Attributes
    ----------
    streaming : bool
        In a session (after a Hello of its version); else silent and vented.
    openings : tuple of float
        The six openings its latest step applied (after the faults): inlets MCP, PIP, DIP,
        then outlets.
    watchdog_tripped : bool
        It vented for want of a valid frame within its watchdog time, and holds the vent until
        the next openings.
    pressures : tuple of int
        The chamber pressures its latest step read and sent (quantised), Pa.
    """

    streaming: bool
    openings: tuple[float, ...]
    watchdog_tripped: bool
    pressures: tuple[int, ...]

    def __str__(self) -> str:
        return (
            f'status {"streaming" if self.streaming else "silent"}, openings '
            + ' '.join(f'{value:g}' for value in self.openings)
            + f', watchdog {"tripped" if self.watchdog_tripped else "fed"}, pressures '
            + ' '.join(map(str, self.pressures))
            + ' Pa'
        )

    @classmethod
    def parse(cls, line: str) -> BoardStatus:
        """The status a ``status`` line says (ValueError for any other line)."""
        found = STATUS_PATTERN.fullmatch(line.strip())
        if found is None:
            raise ValueError(f'{line.strip()!r} is no status line of mcu_emulator')
        return cls(
            streaming=found['state'] == 'streaming',
            openings=tuple(float(word) for word in found['openings'].split()),
            watchdog_tripped=found['watchdog'] == 'tripped',
            pressures=tuple(int(word) for word in found['pressures'].split()),
        )


class Emulator:
    """An :class:`EmulatedBoard` served on a :class:`PseudoTerminal` in real time.

    Call :meth:`run` (blocks), or :meth:`control` with a command line from any thread that
    owns no other part of it (the tests feed commands from standard input instead).
    """

    def __init__(self, settings: EmulatorSettings, link: str, model=None) -> None:
        self.settings = settings
        self.board = EmulatedBoard(settings, model)
        rng = np.random.default_rng(np.random.SeedSequence(settings.seed).spawn(3)[2])
        self.to_host = ByteLine(settings, rng)
        self.to_board = ByteLine(settings, rng)
        self.pty = PseudoTerminal(link)
        self.period = 1.0 / settings.rate_hz
        self.late_ticks = 0
        self.ticks = 0
        self._replug_at = math.inf
        self._unread = b''
        """Bytes of a command line not yet ended."""
        self._start = time.monotonic()

    def now(self) -> float:
        """The board's clock: s since the emulator started."""
        return time.monotonic() - self._start

    def control(self, line: str) -> str:
        """Apply one fault command (module docstring); what it did, one line.

        Raises
        ------
        ValueError
            For an unknown command or a bad argument.
        """
        words = line.split()
        if not words:
            return ''
        command, arguments = words[0], words[1:]
        if command == 'unplug' and len(arguments) <= 1:
            seconds = float(arguments[0]) if arguments else math.inf
            if not seconds > 0:
                raise ValueError(f'unplug {seconds}: seconds must be > 0')
            self.pty.unplug()
            self.to_host.clear()
            self.to_board.clear()
            self.board.power_cycle()
            self._replug_at = self.now() + seconds
            return f'unplugged ({self.pty.link} removed)'
        if command == 'plug' and not arguments:
            self._plug()
            return f'plugged in at {self.pty.link}'
        if command == 'supply' and arguments in (['off'], ['on']):
            self.board.supply_lost = arguments == ['off']
            return f'supply {arguments[0]}'
        if command == 'stick' and len(arguments) == 2:
            valve, opening = int(arguments[0]), float(arguments[1])
            if not (0 <= valve < 2 * CHAMBERS and 0.0 <= opening <= 1.0):
                raise ValueError(f'stick {valve} {opening}: valve 0-5, opening in [0, 1]')
            self.board.stuck[valve] = opening
            return f'valve {valve} stuck at {opening:g}'
        if command == 'unstick' and not arguments:
            self.board.stuck.clear()
            return 'valves free'
        if command == 'status' and not arguments:
            return str(self.status())
        raise ValueError(f'unknown command {line.strip()!r}: see --help')

    def status(self) -> BoardStatus:
        """What the board does now."""
        protocol = self.board.protocol
        return BoardStatus(
            streaming=protocol.streaming,
            openings=tuple(float(value) for value in self.board.openings),
            watchdog_tripped=protocol.watchdog_tripped,
            pressures=tuple(self.board.readings),
        )

    def _plug(self) -> None:
        self.pty.plug()
        self._replug_at = math.inf

    def run(self, duration: float = math.inf, commands=None, stopping=None) -> None:
        """Serve until ``duration`` s pass, ``quit`` comes or ``stopping()`` is true.

        ``commands``: a readable file (standard input, a pipe) of fault commands, one a line,
        read as its bytes come (unbuffered: a command is answered even when the next one is
        written at once); at its end the board runs on. ``stopping``: asked at every turn (a
        stop signal's flag; the longest turn is one sample period).
        """
        next_tick = self.now() + self.period
        end = self.now() + duration
        descriptor = None if commands is None else commands.fileno()
        while self.now() < end and not (stopping is not None and stopping()):
            now = self.now()
            wait = min(next_tick, self.to_host.due(), self.to_board.due(), self._replug_at, end)
            readable = [self.pty.master] if self.pty.plugged else []
            if descriptor is not None:
                readable.append(descriptor)
            ready = select.select(readable, [], [], max(0.0, wait - now))[0] if readable else ()
            if not readable:
                time.sleep(max(0.0, wait - now))
            now = self.now()
            if descriptor is not None and descriptor in ready:
                read = self._read_commands(descriptor)
                if read is True:
                    return
                if read is None:
                    descriptor = None
            if self.pty.plugged and self.pty.master in ready:
                self.to_board.put(self.pty.read(), now)
            if now >= self._replug_at:
                self._plug()
                self._say_line(f'plugged in at {self.pty.link}')
            answer = self.board.receive(self.to_board.take(now), now)
            if self.pty.plugged:
                self.to_host.put(answer, now)
            if now >= next_tick:
                self.ticks += 1
                sample = self.board.tick(now)
                if self.pty.plugged:
                    self.to_host.put(sample, now)
                next_tick += self.period
                if now - next_tick > self.period:  # more than a period behind: catch up
                    self.late_ticks += 1
                    next_tick = now + self.period
            self.pty.write(self.to_host.take(now))

    def _read_commands(self, descriptor: int) -> bool | None:
        """Apply each whole line that came on ``descriptor``.

        True at ``quit``, None at the end of the input, else False.
        """
        chunk = os.read(descriptor, 4096)
        *lines, self._unread = (self._unread + chunk).split(b'\n')
        for line in lines:
            text = line.decode(errors='replace').strip()
            if text == 'quit':
                return True
            if text:
                self._say(text)
        return False if chunk else None

    def _say(self, line: str) -> None:
        try:
            self._say_line(self.control(line))
        except ValueError as error:
            self._say_line(f'refused: {error}')

    @staticmethod
    def _say_line(text: str) -> None:
        print(text, flush=True)

    def close(self) -> None:
        """Unplug for good (the link is removed)."""
        self.pty.close()


def build_parser() -> argparse.ArgumentParser:
    defaults = EmulatorSettings()
    parser = argparse.ArgumentParser(
        prog='mcu_emulator',
        description=__doc__.split('\n\n')[0] + '. Fault commands on standard input: '
        'unplug [SECONDS], plug, supply off|on, stick VALVE OPENING, unstick, status, quit.',
        formatter_class=argparse.ArgumentDefaultsHelpFormatter,
    )
    parser.add_argument('--link', required=True, help='path of the symbolic link to the pty')
    parser.add_argument('--duration', type=float, default=math.inf, help='run this long, s')
    parser.add_argument('--rate-hz', type=float, default=defaults.rate_hz, help='sample rate')
    parser.add_argument('--latency', type=float, default=defaults.latency, help='one way, s')
    parser.add_argument('--pressure-noise-std', type=float, default=defaults.pressure_noise_std,
                        help='Pa')  # fmt: skip
    parser.add_argument('--angle-noise-std', type=float, default=defaults.angle_noise_std,
                        help='rad')  # fmt: skip
    parser.add_argument('--pressure-quantum', type=int, default=defaults.pressure_quantum,
                        help='sensor resolution, Pa')  # fmt: skip
    parser.add_argument('--angle-quantum', type=int, default=defaults.angle_quantum,
                        help='bend sensor resolution, 1/10,000 rad')  # fmt: skip
    parser.add_argument('--no-bend-sensors', action='store_true', help='a board without them')
    parser.add_argument('--drop-probability', type=float, default=defaults.drop_probability,
                        help='per byte, each way')  # fmt: skip
    parser.add_argument('--corrupt-probability', type=float,
                        default=defaults.corrupt_probability,
                        help='per byte, each way')  # fmt: skip
    parser.add_argument('--watchdog', type=float, default=defaults.watchdog, help='s')
    parser.add_argument('--vent-pressure', type=float, default=defaults.vent_pressure, help='Pa')
    parser.add_argument('--supply-pressure', type=float, default=defaults.supply_pressure,
                        help='gauge, Pa')  # fmt: skip
    parser.add_argument('--version', type=int, default=defaults.version,
                        help='protocol version the board speaks')  # fmt: skip
    parser.add_argument('--seed', type=int, default=defaults.seed, help='noise and line faults')
    parser.add_argument('--params-file', action='append', default=[], metavar='FILE',
                        help='model parameter YAML of the glove and finger (docs/spec/model.md '
                        '§10), merged in order; may be repeated (an empty name is ignored); '
                        'default built-in values')  # fmt: skip
    return parser


def load_model(files: list[str]):
    """The glove and finger of the ``--params-file`` files (none: the built-in ones).

    Raises
    ------
    ValueError
        One line naming the file's problem.
    """
    from exodigit_model import GloveModel, ParameterError, load_params

    try:
        return GloveModel(load_params([name for name in files if name]))
    except (ParameterError, OSError, ValueError) as error:
        raise ValueError(f'--params-file: {" ".join(str(error).split())}') from None


def main(argv: list[str] | None = None) -> int:
    """Console script ``mcu_emulator``: 0 once stopped (Ctrl-C, SIGTERM, ``quit``).

    2, with a usage line, for refused options.
    """
    stop = StopRequest()  # a stop while the model loads ends it at once, quietly
    parser = build_parser()
    options = parser.parse_args(argv)
    try:
        settings = EmulatorSettings(
            rate_hz=options.rate_hz,
            latency=options.latency,
            pressure_noise_std=options.pressure_noise_std,
            angle_noise_std=options.angle_noise_std,
            pressure_quantum=options.pressure_quantum,
            angle_quantum=options.angle_quantum,
            bend_sensors=not options.no_bend_sensors,
            drop_probability=options.drop_probability,
            corrupt_probability=options.corrupt_probability,
            watchdog=options.watchdog,
            vent_pressure=options.vent_pressure,
            supply_pressure=options.supply_pressure,
            version=options.version,
            seed=options.seed,
        )
        model = load_model(options.params_file)
    except ValueError as error:
        parser.error(str(error))
    if os.path.exists(options.link) and not os.path.islink(options.link):
        parser.error(f'--link {options.link}: exists and is no symbolic link (not replaced)')
    emulator = Emulator(settings, options.link, model)
    print(
        f'mcu_emulator: board (protocol {settings.version}, {settings.rate_hz:g} Hz) on '
        f'{options.link} -> {os.readlink(options.link)}',
        flush=True,
    )
    try:
        commands = sys.stdin if sys.stdin is not None and not sys.stdin.closed else None
        emulator.run(options.duration, commands, stopping=lambda: stop.requested)
    finally:
        emulator.close()
    return 0


if __name__ == '__main__':
    raise SystemExit(main())
