"""The board's side of the link (docs/spec/hardware.md §6), without I/O.

What every board does, whatever drives its valves: it starts vented and silent; a Hello of its
version starts streaming (answered by its Capabilities, a Hello of another version only by
them); valid Openings are applied, with any chamber at or above the vent pressure vented; no
valid frame for the watchdog time vents every chamber until the next Openings. The emulator
(:mod:`.emulator`) wraps this class; the reference firmware (``firmware/``) is the same state
machine in C, and the suite checks that both give the same bytes.
"""

from __future__ import annotations

from .framing import FrameDecoder, encode_frame
from .messages import (
    BOARD_TIME_MODULO,
    CHAMBERS,
    DUTY_FULL,
    PROTOCOL_VERSION,
    SEQUENCE_MODULO,
    Capabilities,
    Heartbeat,
    Hello,
    MessageType,
    Notice,
    NoticeCode,
    Openings,
    ProtocolError,
    Sample,
    Status,
    decode,
    encode,
)

VENT_DUTIES = (0,) * CHAMBERS + (DUTY_FULL,) * CHAMBERS
"""Inlets closed, outlets fully open."""
HOST_TYPES = frozenset({MessageType.HELLO, MessageType.OPENINGS, MessageType.HEARTBEAT})
"""The types a board takes; any other (a board-to-host type too) is an unknown type to it."""


class BoardProtocol:
    """One board's protocol state: handshake, watchdog, openings, samples.

    Parameters
    ----------
    capabilities : Capabilities
        What the board answers to a Hello; its ``watchdog_ms`` and ``vent_pressure_pa`` are
        the watchdog time and the vent pressure it applies.

    Attributes
    ----------
    streaming : bool
        Whether a Hello of the board's version has started a session.
    commanded : tuple of int
        The host's latest valid openings (the vent before any), 1/10,000.
    applied_sequence : int
        Their sequence number (0 before any).
    """

    def __init__(self, capabilities: Capabilities) -> None:
        self.capabilities = capabilities
        self.decoder = FrameDecoder()
        self.streaming = False
        self.commanded = VENT_DUTIES
        self.applied_sequence = 0
        self.sequence = 0
        self.last_valid: float | None = None
        self.refused = False
        self.over_pressure = (False,) * CHAMBERS
        self._tripped = False
        self._bad_frames = 0

    @property
    def watchdog_tripped(self) -> bool:
        """Whether the watchdog vents (no valid frame in time, and no Openings since)."""
        return self.streaming and self._tripped

    def receive(self, data: bytes, now: float) -> bytes:
        """Take bytes from the host at ``now`` (s); the bytes to answer (Capabilities, Notices)."""
        answer = b''
        for payload in self.decoder.feed(data):
            kind = payload[0]
            if kind not in HOST_TYPES:
                answer += encode_frame(encode(Notice(NoticeCode.UNKNOWN_TYPE, kind)))
                continue
            try:
                message = decode(payload)
            except ProtocolError:
                answer += encode_frame(encode(Notice(NoticeCode.BAD_LENGTH, kind)))
                continue
            answer += self._take(message, now)
        return answer

    def _take(self, message: Hello | Openings | Heartbeat, now: float) -> bytes:
        """Act on one message from the host; the answer's bytes."""
        if isinstance(message, Hello):
            if message.version != self.capabilities.version:
                return encode_frame(encode(self.capabilities))
            self.streaming = True
            self.commanded = VENT_DUTIES
            self.applied_sequence = 0
            self.sequence = 0
            self.refused = False
            self._tripped = False
            self.last_valid = now
            return encode_frame(encode(self.capabilities))
        if not self.streaming:
            kind = MessageType.OPENINGS if isinstance(message, Openings) else MessageType.HEARTBEAT
            return encode_frame(encode(Notice(NoticeCode.NOT_STREAMING, kind)))
        self.last_valid = now
        if isinstance(message, Heartbeat):
            return b''
        over = [i for i, duty in enumerate(message.duties) if duty > DUTY_FULL]
        if over:
            self.refused = True
            return encode_frame(encode(Notice(NoticeCode.BAD_OPENINGS, over[0])))
        self.refused = False
        self._tripped = False
        self.commanded = message.duties
        self.applied_sequence = message.sequence
        return b''

    def duties(self, now: float) -> tuple[int, ...]:
        """The openings the valves get at ``now``: the command, or a vent where the rules say.

        Every chamber vents before a Hello, and from the moment no valid frame came for the
        watchdog time until the next valid Openings; a chamber whose latest pressure (given to
        :meth:`sample`) is at or above the vent pressure vents.
        """
        if self.streaming and now - self.last_valid > self.capabilities.watchdog_ms * 1e-3:
            self._tripped = True
        if not self.streaming or self._tripped:
            return VENT_DUTIES
        duties = list(self.commanded)
        for chamber, over in enumerate(self.over_pressure):
            if over:
                duties[chamber], duties[CHAMBERS + chamber] = 0, DUTY_FULL
        return tuple(duties)

    def sample(
        self,
        now: float,
        pressures_pa: tuple[int, ...],
        angles: tuple[int, ...] = (),
        *,
        supply_low: bool = False,
        sensor_fault: bool = False,
    ) -> bytes:
        """The frame of a sample read at ``now`` (s; b'' before a Hello).

        Also updates the over-pressure vent from ``pressures_pa`` (Pa, as read).
        """
        self.over_pressure = tuple(p >= self.capabilities.vent_pressure_pa for p in pressures_pa)
        if not self.streaming:
            return b''
        self.duties(now)
        status = Status(0)
        if self._tripped:
            status |= Status.WATCHDOG_VENT
        if any(self.over_pressure):
            status |= Status.OVER_PRESSURE
        if supply_low:
            status |= Status.SUPPLY_LOW
        if sensor_fault:
            status |= Status.SENSOR_FAULT
        if self.refused:
            status |= Status.COMMAND_REFUSED
        bad = self.decoder.counts.bad
        if bad != self._bad_frames:
            status |= Status.RECEIVE_ERRORS
            self._bad_frames = bad
        message = Sample(
            sequence=self.sequence,
            board_time_us=round(now * 1e6) % BOARD_TIME_MODULO,
            status=status,
            applied_sequence=self.applied_sequence,
            pressures_pa=pressures_pa,
            angles=angles,
        )
        self.sequence = (self.sequence + 1) % SEQUENCE_MODULO
        return encode_frame(encode(message))

    def reset(self) -> None:
        """Power cycle: silent and vented until the next Hello."""
        self.__init__(self.capabilities)


def default_capabilities(**changes) -> Capabilities:
    """The emulator's Capabilities (a board at 100 Hz with bend sensors), with ``changes``."""
    values = dict(
        version=PROTOCOL_VERSION,
        firmware=(1, 0, 0),
        chambers=CHAMBERS,
        bend_sensors=CHAMBERS,
        sample_rate_hz=100,
        watchdog_ms=200,
        pressure_quantum_pa=50,
        pressure_min_pa=0,
        pressure_max_pa=200_000,
        vent_pressure_pa=150_000,
        angle_quantum=10,
        proportional_valves=True,
        pwm_hz=1000,
    )
    return Capabilities(**(values | changes))
