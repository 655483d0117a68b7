"""The host's side of the link: port, handshake, supervision (docs/spec/hardware.md §7).

:class:`HostLink` owns the port and knows nothing of ROS. Call :meth:`HostLink.poll` often
(every few ms, or when the port's descriptor is readable): it opens the port (again, after a
failure, with exponential backoff), says Hello until the board's Capabilities come, reads
samples, sends heartbeats, notices when samples stop, and returns what happened as events. The
caller decides the openings (:meth:`HostLink.send_openings`) and what to do on each event (the
bridge vents on every :class:`LinkLost`).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, fields
from enum import Enum

from exodigit_model.checks import ParameterError, check_positive

from .framing import FrameDecoder, encode_frame
from .messages import (
    CHAMBERS,
    PROTOCOL_VERSION,
    SEQUENCE_MODULO,
    Capabilities,
    Heartbeat,
    Hello,
    Message,
    Notice,
    Openings,
    ProtocolError,
    Sample,
    decode,
    encode,
)
from .port import PortError, SerialPort
from .timing import BoardClock, RoundTrip


class LinkState(Enum):
    """Where the link is."""

    DISCONNECTED = 'disconnected'
    """No port open: not yet, or it failed (unplugged); reopened after a backoff."""
    HANDSHAKE = 'handshake'
    """Port open, Hello sent, waiting for the board's Capabilities."""
    STREAMING = 'streaming'
    """Capabilities taken, samples arriving."""
    SILENT = 'silent'
    """The samples stopped for ``sample_timeout``: saying Hello again until the board answers."""


class IncompatibleBoardError(Exception):
    """The board speaks another protocol version, or is no glove board (one line)."""


@dataclass(frozen=True)
class LinkSettings:
    """How the host runs the link (s unless said).

    Attributes
    ----------
    port : str
        Serial port name (pyserial), e.g. ``/dev/ttyACM0``.
    baud_rate : int
        Bits per second (8N1).
    handshake_timeout : float
        Longest wait for Capabilities after opening the port; then it is closed and reopened.
        Covers a board that resets when its port opens (an Arduino Uno boots in ~1.5 s).
    hello_interval : float
        Time between two Hellos while waiting for Capabilities.
    sample_timeout : float
        No valid sample for this long: the link is lost (SILENT).
    heartbeat_period : float
        Longest time without a frame to the board; then a Heartbeat goes (below the board's
        watchdog time).
    reconnect_min, reconnect_max : float
        First and largest wait before reopening the port; doubled at each failure in a row.
    """

    port: str
    baud_rate: int = 115200
    handshake_timeout: float = 3.0
    hello_interval: float = 0.25
    sample_timeout: float = 0.1
    heartbeat_period: float = 0.05
    reconnect_min: float = 0.1
    reconnect_max: float = 2.0

    def __post_init__(self) -> None:
        """Refuse values that break a rule, naming the field, the value and the rule."""
        if not isinstance(self.port, str) or not self.port:
            raise ParameterError(f'port = {self.port!r}: must name a serial port')
        for item in fields(self)[1:]:
            unit = 'bit/s' if item.name == 'baud_rate' else 's'
            check_positive(item.name, getattr(self, item.name), unit)
        if self.reconnect_max < self.reconnect_min:
            raise ParameterError(
                f'reconnect_max = {self.reconnect_max!r}: must be >= reconnect_min '
                f'({self.reconnect_min!r})'
            )


@dataclass(frozen=True)
class Connected:
    """The board answered the Hello: a new session; it is vented and streams from now."""

    capabilities: Capabilities


@dataclass(frozen=True)
class SampleReceived:
    """A sample, with the host time it arrived and the host time it was read (s)."""

    sample: Sample
    received: float
    stamp: float
    lost: int
    """Samples missing between the previous one and this (sequence gap)."""


@dataclass(frozen=True)
class LinkLost:
    """The link went from streaming to lost (or the port failed); ``reason`` in one line."""

    state: LinkState
    reason: str


@dataclass(frozen=True)
class NoticeReceived:
    """The board refused something (:class:`~.messages.Notice`)."""

    notice: Notice


Event = Connected | SampleReceived | LinkLost | NoticeReceived


def check_capabilities(capabilities: Capabilities) -> None:
    """An :class:`IncompatibleBoardError` unless the board speaks our version to a glove of 3."""
    if capabilities.version != PROTOCOL_VERSION:
        raise IncompatibleBoardError(
            f'the board speaks protocol version {capabilities.version}, this bridge version '
            f'{PROTOCOL_VERSION} (docs/spec/hardware.md): update the firmware or the bridge'
        )
    if capabilities.chambers != CHAMBERS or capabilities.bend_sensors not in (0, CHAMBERS):
        raise IncompatibleBoardError(
            f'the board drives {capabilities.chambers} chambers with '
            f'{capabilities.bend_sensors} bend sensors: a glove board has {CHAMBERS} chambers '
            f'and 0 or {CHAMBERS} bend sensors'
        )
    if capabilities.sample_rate_hz == 0 or capabilities.watchdog_ms == 0:
        raise IncompatibleBoardError('the board reports a sample rate or watchdog time of 0')


class HostLink:
    """The host's end of the link.

    Parameters
    ----------
    settings : LinkSettings
        Port and timings.
    opener : callable, optional
        ``opener(name, baud_rate)`` gives an open port (:class:`~.port.SerialPort`, the
        default) or raises :class:`~.port.PortError`.

    Attributes
    ----------
    state : LinkState
    capabilities : Capabilities or None
        The current (or last) board's.
    decoder : FrameDecoder
        Its ``counts`` are the frames received, good and bad, since the link was made.
    undecodable : int
        Frames with a good CRC that are no message of this version.
    lost_samples : int
        Samples missing from the sequence numbers.
    sessions : int
        Handshakes completed.
    round_trip : RoundTrip
        Openings sent to the first sample that applies them.
    """

    def __init__(
        self, settings: LinkSettings, opener: Callable[[str, int], SerialPort] = SerialPort
    ) -> None:
        self.settings = settings
        self.opener = opener
        self.state = LinkState.DISCONNECTED
        self.port: SerialPort | None = None
        self.capabilities: Capabilities | None = None
        self.decoder = FrameDecoder()
        self.clock = BoardClock()
        self.round_trip = RoundTrip()
        self.undecodable = 0
        self.lost_samples = 0
        self.samples = 0
        self.sessions = 0
        self.failures = 0
        """Opening or handshake failures in a row (the backoff's exponent)."""
        self.last_error = ''
        self._next_open = -math.inf
        self._opened = 0.0
        self._last_hello = -math.inf
        self._last_sample = 0.0
        self._last_sent = -math.inf
        self._expected: int | None = None
        self._sequence = 0

    # -- what the caller does --------------------------------------------------------------

    def poll(self, now: float) -> list[Event]:
        """Do what is due at ``now`` (host monotonic time, s); the events, in order.

        Raises
        ------
        IncompatibleBoardError
            When a board answers with another protocol version or shape (the port is closed).
        """
        events: list[Event] = []
        if self.port is None and now >= self._next_open:
            self._open(now)
        if self.port is None:
            return events
        try:
            data = self.port.read()
        except PortError as error:
            self._fail(now, str(error), events)
            return events
        for payload in self.decoder.feed(data):
            try:
                message = decode(payload)
            except ProtocolError:
                self.undecodable += 1
                continue
            self._take(message, now, events)
        self._supervise(now, events)
        return events

    def send_openings(self, duties: tuple[int, ...], now: float) -> int | None:
        """Send Openings (duties 0-10,000); their sequence, or None if not sent.

        Sent while streaming, and while silent (a board that still hears the host takes a
        vent); not while the port is closed or the handshake is on.
        """
        if self.state not in (LinkState.STREAMING, LinkState.SILENT):
            return None
        self._sequence = self._sequence % (SEQUENCE_MODULO - 1) + 1  # 1 .. 65535: 0 is none
        if not self._send(Openings(self._sequence, tuple(duties)), now):
            return None
        self.round_trip.sent(self._sequence, now)
        return self._sequence

    def close(self) -> None:
        """Close the port (what was written is flushed by the driver)."""
        if self.port is not None:
            self.port.close()
            self.port = None
        self.state = LinkState.DISCONNECTED

    def fileno(self) -> int | None:
        """The port's descriptor to wait on (None when closed or without one)."""
        return None if self.port is None else self.port.fileno()

    # -- inside ----------------------------------------------------------------------------

    def _open(self, now: float) -> None:
        try:
            self.port = self.opener(self.settings.port, self.settings.baud_rate)
            self.port.discard_input()
        except PortError as error:
            self.port = None
            self._backoff(now, str(error))
            return
        self.decoder.discard()
        self.state = LinkState.HANDSHAKE
        self._opened = now
        self._hello(now)

    def _hello(self, now: float) -> None:
        self._last_hello = now
        self._send(Hello(PROTOCOL_VERSION), now)

    def _send(self, message: Message, now: float) -> bool:
        if self.port is None:
            return False
        try:
            self.port.write(encode_frame(encode(message)))
        except PortError as error:
            self._fail(now, str(error), [])
            return False
        self._last_sent = now
        return True

    def _take(self, message: Message, now: float, events: list[Event]) -> None:
        if isinstance(message, Capabilities):
            if self.state in (LinkState.HANDSHAKE, LinkState.SILENT):
                try:
                    check_capabilities(message)
                except IncompatibleBoardError:
                    self.close()
                    raise
                self.capabilities = message
                self.state = LinkState.STREAMING
                self.sessions += 1
                self.failures = 0
                self.clock.reset()
                self._expected = None
                self._last_sample = now
                events.append(Connected(message))
        elif isinstance(message, Sample):
            if self.state is not LinkState.STREAMING:
                return  # a stale sample of a session the host has not (re)started
            lost = 0
            if self._expected is not None:
                lost = (message.sequence - self._expected) % SEQUENCE_MODULO
            self._expected = (message.sequence + 1) % SEQUENCE_MODULO
            self.lost_samples += lost
            self.samples += 1
            self._last_sample = now
            self.round_trip.applied(message.applied_sequence, now)
            stamp = self.clock.host_time(message.board_time_us, now)
            events.append(SampleReceived(message, now, stamp, lost))
        elif isinstance(message, Notice):
            events.append(NoticeReceived(message))
        else:
            self.undecodable += 1  # a host-to-board message on our input: not for us

    def _supervise(self, now: float, events: list[Event]) -> None:
        settings = self.settings
        if self.state is LinkState.HANDSHAKE:
            if now - self._opened > settings.handshake_timeout:
                self._fail(
                    now,
                    f'no answer to hello from {settings.port} within '
                    f'{settings.handshake_timeout:g} s',
                    events,
                )
            elif now - self._last_hello >= settings.hello_interval:
                self._hello(now)
        elif self.state is LinkState.STREAMING:
            if now - self._last_sample > settings.sample_timeout:
                self.state = LinkState.SILENT
                self.last_error = f'no valid sample for {settings.sample_timeout:g} s'
                events.append(LinkLost(self.state, self.last_error))
                self._hello(now)
            elif now - self._last_sent >= settings.heartbeat_period:
                self._send(Heartbeat(), now)
        elif self.state is LinkState.SILENT and now - self._last_hello >= settings.hello_interval:
            self._hello(now)

    def _fail(self, now: float, reason: str, events: list[Event]) -> None:
        """The port failed (or no board answered): close it, reopen after a backoff."""
        was = self.state
        self.close()
        self._backoff(now, reason)
        if was in (LinkState.STREAMING, LinkState.SILENT):
            events.append(LinkLost(LinkState.DISCONNECTED, reason))

    def _backoff(self, now: float, reason: str) -> None:
        self.last_error = reason
        wait = min(self.settings.reconnect_min * 2.0**self.failures, self.settings.reconnect_max)
        self.failures += 1
        self._next_open = now + wait
