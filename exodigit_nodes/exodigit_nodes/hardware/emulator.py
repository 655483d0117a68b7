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

``unplug [SECONDS]``  the USB cable out (the pty and the link vanish; the board loses power and
                      vents); back after SECONDS, or at ``plug``
``plug``              the cable back in (the board boots: silent and vented until a Hello)
``supply off|on``     the supply lost (no air comes through the inlets; the board flags it) or
                      back
``stick VALVE OPENING`` valve 0-5 (inlets MCP, PIP, DIP, then outlets) stays at OPENING in [0, 1]
                      whatever is commanded; ``unstick`` frees them
``status``            print one line: streaming or silent, the openings applied, the watchdog
``quit``              stop

Run: ``python -m exodigit_nodes.hardware.emulator --link /tmp/glove_board`` (``--help``).
"""

from __future__ import annotations

import argparse
import contextlib
import heapq
import math
import os
import select
import signal
import sys
import time
import tty
from dataclasses import dataclass, fields

import numpy as np

from .board import BoardProtocol, default_capabilities
from .messages import ANGLE_UNIT, CHAMBERS, PROTOCOL_VERSION, openings_of

FIRMWARE = (1, 0, 0)
"""The emulator's firmware version, in its Capabilities."""


@dataclass(frozen=True)
class EmulatorSettings:
    """The emulated board and its line (SI units).

    Attributes
    ----------
    rate_hz : float
        Samples (and simulation steps) per second, Hz; a whole number up to 2000.
    latency : float
        One-way delay of every byte, both ways, s.
    pressure_noise_std : float
        Pressure sensor noise (std), Pa.
    angle_noise_std : float
        Bend sensor noise (std), rad.
    pressure_quantum : int
        Pressure sensor resolution, Pa (≥ 1).
    angle_quantum : int
        Bend sensor resolution, in 1/10,000 rad (≥ 1).
    bend_sensors : bool
        Whether the board has a bend sensor per joint.
    drop_probability, corrupt_probability : float
        Chance that a byte is lost, or has one bit flipped, each way, in [0, 1).
    watchdog : float
        The board's watchdog time, s (whole ms, 0.001-60).
    vent_pressure : float
        The board's vent pressure, Pa.
    supply_pressure : float
        Supply pressure (gauge), Pa, unless the model's pneumatics sets one.
    pressure_max : float
        Top of the pressure sensors' range (gauge), Pa; readings are clipped to [0, this].
    version : int
        Protocol version the board speaks (another than the host's to test the refusal).
    seed : int
        Seed of the sensor noise and of the line faults.
    """

    rate_hz: float = 100.0
    latency: float = 0.0
    pressure_noise_std: float = 0.0
    angle_noise_std: float = 0.0
    pressure_quantum: int = 50
    angle_quantum: int = 10
    bend_sensors: bool = True
    drop_probability: float = 0.0
    corrupt_probability: float = 0.0
    watchdog: float = 0.2
    vent_pressure: float = 150e3
    supply_pressure: float = 100e3
    pressure_max: float = 200e3
    version: int = PROTOCOL_VERSION
    seed: int = 0

    def __post_init__(self) -> None:
        """Refuse values that break a rule, naming the field, the value and the rule."""
        for item in fields(self):
            value = getattr(self, item.name)
            if item.name == 'bend_sensors':
                if not isinstance(value, bool):
                    raise ValueError(f'bend_sensors = {value!r}: must be true or false')
                continue
            if isinstance(value, bool) or not isinstance(value, int | float):
                raise ValueError(f'{item.name} = {value!r}: must be a number')
            if not math.isfinite(value) or value < 0:
                raise ValueError(f'{item.name} = {value!r}: must be finite and >= 0')
        rules = (
            ('rate_hz', 1 <= self.rate_hz <= 2000 and self.rate_hz == int(self.rate_hz),
             'a whole number in [1, 2000]'),
            ('pressure_quantum', isinstance(self.pressure_quantum, int)
             and self.pressure_quantum >= 1, 'an integer >= 1'),
            ('angle_quantum', isinstance(self.angle_quantum, int) and self.angle_quantum >= 1,
             'an integer >= 1'),
            ('drop_probability', self.drop_probability < 1, 'below 1'),
            ('corrupt_probability', self.corrupt_probability < 1, 'below 1'),
            ('watchdog', 1e-3 <= self.watchdog <= 60, 'in [0.001, 60]'),
            ('supply_pressure', self.supply_pressure >= 1e3, '>= 1000'),
            ('pressure_max', self.pressure_max >= 1e3, '>= 1000'),
            ('version', isinstance(self.version, int) and self.version <= 255,
             'an integer in [0, 255]'),
            ('seed', isinstance(self.seed, int), 'an integer'),
        )  # fmt: skip
        for name, good, rule in rules:
            if not good:
                raise ValueError(f'{name} = {getattr(self, name)!r}: must be {rule}')


class EmulatedBoard:
    """The glove behind valves and the board's protocol, stepped by :meth:`tick`; no I/O.

    Parameters
    ----------
    settings : EmulatorSettings
    model : exodigit_model.GloveModel, optional
        The glove and finger (the defaults when omitted).

    Attributes
    ----------
    protocol : BoardProtocol
    simulation : exodigit_model.GloveSimulation
    supply_lost : bool
        No air comes through the inlets (and the board flags SUPPLY_LOW).
    stuck : dict
        Valve index (0-5) -> the opening it is stuck at.
    openings : ndarray
        The openings of the latest step, after the faults.
    """

    def __init__(self, settings: EmulatorSettings, model=None) -> None:
        from exodigit_model import GloveSimulation, SimulationSettings

        self.settings = settings
        self.capabilities = default_capabilities(
            version=settings.version,
            firmware=FIRMWARE,
            bend_sensors=CHAMBERS if settings.bend_sensors else 0,
            sample_rate_hz=int(settings.rate_hz),
            watchdog_ms=round(settings.watchdog * 1e3),
            pressure_quantum_pa=settings.pressure_quantum,
            pressure_max_pa=round(settings.pressure_max),
            vent_pressure_pa=round(settings.vent_pressure),
            angle_quantum=settings.angle_quantum if settings.bend_sensors else 0,
        )
        self.protocol = BoardProtocol(self.capabilities)
        self.simulation = GloveSimulation(
            model,
            SimulationSettings(
                rate_hz=settings.rate_hz,
                max_supply_pressure=settings.supply_pressure,
                pressure_noise_std=settings.pressure_noise_std,
                angle_noise_std=settings.angle_noise_std,
                seed=settings.seed,
            ),
            actuation='valves',
        )
        self.supply_lost = False
        self.stuck: dict[int, float] = {}
        self.openings = openings_of(self.protocol.duties(0.0))
        self.simulation.step(self.openings)  # loads the compiled kernels before serving
        self.simulation.reset()

    def receive(self, data: bytes, now: float) -> bytes:
        """Bytes from the host at ``now`` (s); the answer's bytes."""
        return self.protocol.receive(data, now)

    def tick(self, now: float) -> bytes:
        """One step of the glove with the board's openings at ``now``; the sample's frame."""
        openings = openings_of(self.protocol.duties(now))
        for valve, opening in self.stuck.items():
            openings[valve] = opening
        if self.supply_lost:
            openings[:CHAMBERS] = 0.0
        self.openings = openings
        state = self.simulation.step(openings)
        return self.protocol.sample(
            now,
            self.pressures(state.pressure_measured),
            self.angles(state.q_measured),
            supply_low=self.supply_lost,
        )

    def pressures(self, measured) -> tuple[int, ...]:
        """Sensor readings of pressures (Pa): quantised, clipped to the sensor's range, Pa."""
        quantum = self.settings.pressure_quantum
        counts = np.rint(np.asarray(measured) / quantum)
        top = math.floor(self.settings.pressure_max / quantum)
        return tuple(int(c) * quantum for c in np.clip(counts, 0, top))

    def angles(self, measured) -> tuple[int, ...]:
        """Bend sensor readings (1/10,000 rad, quantised), or () without bend sensors."""
        if not self.settings.bend_sensors:
            return ()
        quantum = self.settings.angle_quantum
        counts = np.rint(np.asarray(measured) / (ANGLE_UNIT * quantum))
        limit = 32767 // quantum
        return tuple(int(c) * quantum for c in np.clip(counts, -limit, limit))

    def power_cycle(self) -> None:
        """The board loses power and boots: silent and vented until a Hello."""
        self.protocol.reset()


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
            protocol = self.board.protocol
            return (
                f'status {"streaming" if protocol.streaming else "silent"}, openings '
                + ' '.join(f'{value:g}' for value in self.board.openings)
                + f', watchdog {"tripped" if protocol.watchdog_tripped else "fed"}'
            )
        raise ValueError(f'unknown command {line.strip()!r}: see --help')

    def _plug(self) -> None:
        self.pty.plug()
        self._replug_at = math.inf

    def run(self, duration: float = math.inf, commands=None) -> None:
        """Serve until ``duration`` s have passed or ``quit`` comes on ``commands``.

        ``commands``: a readable text file (standard input, a pipe) of fault commands, one a
        line; at its end the board runs on.
        """
        next_tick = self.now() + self.period
        end = self.now() + duration
        commands_open = commands is not None
        while self.now() < end:
            now = self.now()
            wait = min(next_tick, self.to_host.due(), self.to_board.due(), self._replug_at, end)
            readable = [self.pty.master] if self.pty.plugged else []
            if commands_open:
                readable.append(commands)
            ready = select.select(readable, [], [], max(0.0, wait - now))[0] if readable else ()
            if not readable:
                time.sleep(max(0.0, wait - now))
            now = self.now()
            if commands_open and commands in ready:
                line = commands.readline()
                if not line:
                    commands_open = False
                elif line.strip() == 'quit':
                    return
                else:
                    self._say(line)
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
    return parser


def main(argv: list[str] | None = None) -> int:
    """Console script ``mcu_emulator``."""
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
    except ValueError as error:
        parser.error(str(error))
    if os.path.exists(options.link) and not os.path.islink(options.link):
        parser.error(f'--link {options.link}: exists and is no symbolic link (not replaced)')
    emulator = Emulator(settings, options.link)
    # SIGTERM (a runner stopping it) ends it as Ctrl-C does: the link is removed.
    signal.signal(signal.SIGTERM, signal.default_int_handler)
    print(
        f'mcu_emulator: board (protocol {settings.version}, {settings.rate_hz:g} Hz) on '
        f'{options.link} -> {os.readlink(options.link)}',
        flush=True,
    )
    try:
        with contextlib.suppress(KeyboardInterrupt):
            emulator.run(options.duration, sys.stdin if not sys.stdin.closed else None)
    finally:
        emulator.close()
    return 0


if __name__ == '__main__':
    raise SystemExit(main())
