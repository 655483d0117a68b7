"""The link's messages and their byte layouts (docs/spec/hardware.md §3).

A payload is one type byte and a body of little-endian fields, packed without padding. Host to
board: :class:`Hello`, :class:`Openings`, :class:`Heartbeat`; board to host:
:class:`Capabilities`, :class:`Sample`, :class:`Notice`. :func:`encode` gives a message's
payload, :func:`decode` the message of a payload (a :class:`ProtocolError` for any payload that
is not one of them, exactly). Units on the wire are integers: openings in 1/10,000, pressures in
Pa (gauge), angles in 1/10,000 rad, times in µs.
"""

from __future__ import annotations

import struct
from dataclasses import dataclass
from enum import IntEnum, IntFlag

import numpy as np

PROTOCOL_VERSION = 1
"""The version of docs/spec/hardware.md this module speaks."""
CHAMBERS = 3
"""Chambers of a glove: MCP, PIP, DIP (and so inlet and outlet valves, and bend sensors)."""
DUTY_FULL = 10_000
"""An opening of 1 (valve fully open, or on for the whole PWM period) on the wire."""
ANGLE_UNIT = 1e-4
"""A bend angle's unit on the wire, rad."""
SEQUENCE_MODULO = 1 << 16
"""Sequence numbers (samples, commands) are u16 and wrap."""
BOARD_TIME_MODULO = 1 << 32
"""The board's clock is u32 µs and wraps (every 71.6 minutes)."""


class MessageType(IntEnum):
    """The type byte, first in every payload; host-to-board below 0x80, board-to-host above."""

    HELLO = 0x01
    OPENINGS = 0x02
    HEARTBEAT = 0x03
    CAPABILITIES = 0x81
    SAMPLE = 0x82
    NOTICE = 0x83


class Status(IntFlag):
    """A sample's status flags (u16)."""

    WATCHDOG_VENT = 0x0001
    """The board heard no valid frame for its watchdog time and vents every chamber."""
    OVER_PRESSURE = 0x0002
    """A chamber is at or above the board's vent pressure: the board vents it."""
    SUPPLY_LOW = 0x0004
    """The supply pressure is below what the board needs (boards that measure it)."""
    SENSOR_FAULT = 0x0008
    """A sensor reads outside its range (unplugged, broken): its value is not to be trusted."""
    COMMAND_REFUSED = 0x0010
    """The latest openings were refused (a duty above 10,000): the board keeps the ones before."""
    RECEIVE_ERRORS = 0x0020
    """The board threw away a frame (bad CRC, stuffing or length) since its previous sample."""


class NoticeCode(IntEnum):
    """Why the board sent a :class:`Notice`."""

    BAD_OPENINGS = 1
    """An opening above 10,000; ``detail``: its index (0-5)."""
    UNKNOWN_TYPE = 2
    """A message type the board does not know; ``detail``: the type byte."""
    BAD_LENGTH = 3
    """A known type with a body of the wrong length; ``detail``: the type byte."""
    NOT_STREAMING = 4
    """Openings or a heartbeat before a valid hello; ``detail``: the type byte."""


class ProtocolError(ValueError):
    """A payload that is no valid message of this protocol version."""


@dataclass(frozen=True)
class Hello:
    """Host to board: start (or restart) a session in ``version``; answered by Capabilities."""

    version: int = PROTOCOL_VERSION


@dataclass(frozen=True)
class Openings:
    """Host to board: the six valve openings, each in [0, DUTY_FULL] (1/10,000).

    ``duties``: inlets of MCP, PIP, DIP, then outlets, as on ``valve_command``; ``sequence``
    (u16) is echoed by every later sample as ``applied_sequence`` once the board applies them.
    """

    sequence: int
    duties: tuple[int, ...]


@dataclass(frozen=True)
class Heartbeat:
    """Host to board: nothing to change, the host is there (feeds the board's watchdog)."""


@dataclass(frozen=True)
class Capabilities:
    """Board to host: what the board is, in answer to every Hello.

    Attributes
    ----------
    version : int
        The protocol version the board speaks.
    firmware : tuple of int
        Firmware version (major, minor, patch).
    chambers : int
        Chambers (and pressure sensors) the board drives; 3.
    bend_sensors : int
        Bend sensors (one per joint: MCP, PIP, DIP), 0 or 3.
    sample_rate_hz : int
        Samples per second while streaming, Hz.
    watchdog_ms : int
        Time without a valid frame after which the board vents, ms.
    pressure_quantum_pa : int
        The pressure sensors' resolution (one count), Pa.
    pressure_min_pa, pressure_max_pa : int
        The pressure sensors' range (gauge), Pa.
    vent_pressure_pa : int
        The board's own limit: a chamber at or above it is vented, Pa.
    angle_quantum : int
        The bend sensors' resolution, in 1/10,000 rad (0 without bend sensors).
    proportional_valves : bool
        Whether the valves take any duty (PWM), or only 0 and DUTY_FULL (on/off: the board
        opens a valve for a duty of at least half).
    pwm_hz : int
        The valves' PWM frequency, Hz (0 for on/off valves).
    """

    version: int
    firmware: tuple[int, int, int]
    chambers: int
    bend_sensors: int
    sample_rate_hz: int
    watchdog_ms: int
    pressure_quantum_pa: int
    pressure_min_pa: int
    pressure_max_pa: int
    vent_pressure_pa: int
    angle_quantum: int
    proportional_valves: bool
    pwm_hz: int


@dataclass(frozen=True)
class Sample:
    """Board to host: one sample of the sensors.

    Attributes
    ----------
    sequence : int
        u16, +1 per sample since the last accepted Hello (a gap is samples lost).
    board_time_us : int
        The board's clock when the sensors were read, µs (u32, wraps).
    status : Status
        Flags.
    applied_sequence : int
        ``sequence`` of the Openings the board applies (0 before any).
    pressures_pa : tuple of int
        Chamber pressures (gauge), Pa: MCP, PIP, DIP.
    angles : tuple of int
        Bend angles in 1/10,000 rad (MCP, PIP, DIP), or () without bend sensors.
    """

    sequence: int
    board_time_us: int
    status: Status
    applied_sequence: int
    pressures_pa: tuple[int, ...]
    angles: tuple[int, ...] = ()


@dataclass(frozen=True)
class Notice:
    """Board to host: something the board refused (:class:`NoticeCode`, and a detail byte)."""

    code: int
    detail: int


Message = Hello | Openings | Heartbeat | Capabilities | Sample | Notice

LAYOUTS = {
    MessageType.HELLO: struct.Struct('<B'),
    MessageType.OPENINGS: struct.Struct('<H6H'),
    MessageType.HEARTBEAT: struct.Struct('<'),
    MessageType.CAPABILITIES: struct.Struct('<BBBBBBHHHiiiHBH'),
    MessageType.SAMPLE: struct.Struct('<HIHH3i'),
    MessageType.NOTICE: struct.Struct('<BB'),
}
"""The body of each type (struct format, little-endian, no padding); a sample's bend angles
(3 × int16) follow its body when the board has bend sensors."""
ANGLES = struct.Struct('<3h')


def encode(message: Message) -> bytes:
    """The payload of ``message`` (type byte, then body).

    Raises
    ------
    ValueError
        (struct.error is one) if a field does not fit its wire type.
    """
    if isinstance(message, Hello):
        return _payload(MessageType.HELLO, message.version)
    if isinstance(message, Openings):
        return _payload(MessageType.OPENINGS, message.sequence, *message.duties)
    if isinstance(message, Heartbeat):
        return _payload(MessageType.HEARTBEAT)
    if isinstance(message, Capabilities):
        fields = (
            message.version,
            *message.firmware,
            message.chambers,
            message.bend_sensors,
            message.sample_rate_hz,
            message.watchdog_ms,
            message.pressure_quantum_pa,
            message.pressure_min_pa,
            message.pressure_max_pa,
            message.vent_pressure_pa,
            message.angle_quantum,
            int(message.proportional_valves),
            message.pwm_hz,
        )
        return _payload(MessageType.CAPABILITIES, *fields)
    if isinstance(message, Sample):
        body = _payload(
            MessageType.SAMPLE,
            message.sequence,
            message.board_time_us,
            int(message.status),
            message.applied_sequence,
            *message.pressures_pa,
        )
        return body + (ANGLES.pack(*message.angles) if message.angles else b'')
    if isinstance(message, Notice):
        return _payload(MessageType.NOTICE, message.code, message.detail)
    raise TypeError(f'not a message of the link: {message!r}')


def _payload(kind: MessageType, *fields: int) -> bytes:
    try:
        return bytes([kind]) + LAYOUTS[kind].pack(*fields)
    except struct.error as error:
        raise ValueError(f'{kind.name}: a field does not fit its wire type ({error})') from None


def decode(payload: bytes) -> Message:
    """The message of a checked payload (:class:`ProtocolError` for anything else)."""
    if not payload:
        raise ProtocolError('empty payload')
    try:
        kind = MessageType(payload[0])
    except ValueError:
        raise ProtocolError(f'unknown message type 0x{payload[0]:02x}') from None
    body = payload[1:]
    layout = LAYOUTS[kind]
    extra = len(body) - layout.size
    if kind is MessageType.SAMPLE and extra == ANGLES.size:
        extra = 0
    if extra != 0:
        raise ProtocolError(
            f'{kind.name} of {len(body)} bytes: its body has {layout.size} bytes'
            + (f' or {layout.size + ANGLES.size}' if kind is MessageType.SAMPLE else '')
        )
    fields = layout.unpack_from(body)
    if kind is MessageType.HELLO:
        return Hello(*fields)
    if kind is MessageType.OPENINGS:
        return Openings(fields[0], tuple(fields[1:]))
    if kind is MessageType.HEARTBEAT:
        return Heartbeat()
    if kind is MessageType.CAPABILITIES:
        return Capabilities(
            fields[0], tuple(fields[1:4]), *fields[4:13], bool(fields[13]), fields[14]
        )
    if kind is MessageType.SAMPLE:
        angles = ANGLES.unpack_from(body, layout.size) if len(body) > layout.size else ()
        return Sample(fields[0], fields[1], Status(fields[2]), fields[3], fields[4:7], angles)
    return Notice(*fields)


def duties_of(openings) -> tuple[int, ...]:
    """Six openings in [0, 1] (checked by the caller) as wire duties, nearest 1/10,000."""
    return tuple(round(float(value) * DUTY_FULL) for value in openings)


def openings_of(duties) -> np.ndarray:
    """Wire duties as openings in [0, 1]."""
    return np.asarray(duties, dtype=float) / DUTY_FULL
