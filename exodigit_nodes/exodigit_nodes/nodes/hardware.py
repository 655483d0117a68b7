"""``hardware``: the bridge to a glove board over a serial port (docs/hardware.md).

It takes the simulated plant's place behind valves (``plant actuation:=valves``): each
``valve_command`` goes to the board (docs/spec/hardware.md) after the safety rules of
docs/hardware.md, "Safety", and is answered on ``applied_command`` with the openings sent, taken
or refused, as is every vent. Every sample of the board is published as ``chamber_pressure``
and, when the board has bend sensors, ``joint_states`` (stamped with the time the board read
them, on this host's clock; without them there is no ``joint_states`` publisher). A wall-clock
node: a real board has no simulated time.

Run, e.g. with the emulated board::

    mcu_emulator --link /tmp/glove_board &
    python -m exodigit_nodes.nodes.hardware --ros-args -p port:=/tmp/glove_board
"""

from __future__ import annotations

import select
import threading
import time
from array import array
from dataclasses import fields

from diagnostic_msgs.msg import DiagnosticStatus
from sensor_msgs.msg import JointState
from std_msgs.msg import Float64MultiArray

from exodigit_model import JOINT_NAMES

from ..hardware.bridge import Bridge, BridgeSettings, Limited, Sent, Vented
from ..hardware.link import (
    Connected,
    HostLink,
    IncompatibleBoardError,
    LinkLost,
    LinkSettings,
    LinkState,
    NoticeReceived,
    SampleReceived,
)
from ..hardware.messages import ANGLE_UNIT, NoticeCode, Status
from ..hardware.timing import HostClock
from ..logic.inputs import InvalidInputError, valve_openings
from .catalog import HARDWARE_NODE
from .messages import (
    APPLIED_COMMAND,
    CHAMBER_PRESSURE,
    JOINT_STATES,
    VALVE_COMMAND,
    fill,
    joint_vector_message,
    valve_command_message,
)
from .node_base import LOG_THROTTLE, ConfigurationError, GloveNode
from .process import run
from .qos import APPLIED_QOS, READER_QOS, STREAM_QOS

POLL_PERIOD = 0.005
"""Longest time the link thread waits for bytes before it looks at its timers, s."""
STOP_WAIT = 1.0
"""Longest wait for the link thread to end at shutdown, s."""
VENT_FLUSH = 0.05
"""Time given to the last vent to leave before the port closes, s."""


class Hardware(GloveNode):
    """The bridge node: :class:`~exodigit_nodes.hardware.bridge.Bridge` on ROS topics."""

    executable = HARDWARE_NODE.executable
    table = HARDWARE_NODE.table

    def __init__(self, **node_options) -> None:
        super().__init__(**node_options)
        values = self.values
        # The link's settings that are parameters, of the same names; the others keep defaults.
        shared = values.keys() & {item.name for item in fields(LinkSettings)}
        self.link = HostLink(LinkSettings(**{name: values[name] for name in shared}))
        self.bridge = Bridge(self.link, self.settings)
        self.link_lock = threading.Lock()
        self.pressure_message = joint_vector_message()
        self.applied_message = valve_command_message()
        self.joint_state = JointState(name=[values['joint_prefix'] + n for n in JOINT_NAMES])
        self.host_clock = HostClock()
        self.flags = Status(0)
        self.notices = 0
        self.pressure_publisher = self.create_publisher(
            Float64MultiArray, CHAMBER_PRESSURE, STREAM_QOS
        )
        self.applied_publisher = self.create_publisher(
            Float64MultiArray, APPLIED_COMMAND, APPLIED_QOS
        )
        # What the board is told before any command, as a plant's record starts.
        self.applied_publisher.publish(fill(self.applied_message, self.bridge.openings))
        self.joint_publisher = None
        self.first_session()
        self.create_subscription(Float64MultiArray, VALVE_COMMAND, self.on_command, READER_QOS)
        self.create_timer(values['diagnostic_period'], self.report)
        self.stopping = threading.Event()
        self.thread = threading.Thread(target=self.serve_link, name='board link', daemon=True)
        self.thread.start()

    def make_settings(self, values) -> BridgeSettings:
        """The bridge's safety settings from checked parameters."""
        return BridgeSettings(
            max_pressure=values['max_pressure'], command_timeout=values['command_timeout']
        )

    def apply(self, settings: BridgeSettings, changed: set[str]) -> None:
        with self.link_lock:
            self.bridge.settings = settings

    # -- the link --------------------------------------------------------------------------

    def first_session(self) -> None:
        """Try the board for ``handshake_timeout`` before spinning.

        A board of another protocol version refuses the start (ConfigurationError). No board
        by then is no reason not to start: the link thread goes on trying, the diagnostics say
        ERROR meanwhile.
        """
        deadline = time.monotonic() + self.link.settings.handshake_timeout + POLL_PERIOD
        while time.monotonic() < deadline:
            try:
                events = self.bridge.poll(time.monotonic())
            except IncompatibleBoardError as error:
                raise ConfigurationError(f'{self.link.settings.port}: {error}') from None
            self.take_events(events)
            if self.link.state is LinkState.STREAMING:
                return
            time.sleep(POLL_PERIOD)
        self.get_logger().error(
            f'no board on {self.link.settings.port} yet ({self.link.last_error or "no answer"})'
            ': retrying; valve_command is not applied until it answers'
        )

    def serve_link(self) -> None:
        """The link thread: wait for bytes, run the bridge, publish what it says."""
        while not self.stopping.is_set():
            descriptor = self.link.fileno()  # None: no port open, or none to wait on
            try:
                select.select([] if descriptor is None else [descriptor], [], [], POLL_PERIOD)
            except (OSError, ValueError):  # closed meanwhile (the poll will say why), or Windows
                time.sleep(POLL_PERIOD)
            with self.link_lock:
                if self.stopping.is_set():
                    return
                try:
                    events = self.bridge.poll(time.monotonic())
                except IncompatibleBoardError as error:
                    self.get_logger().error(
                        f'{self.link.settings.port}: {error}; retrying',
                        throttle_duration_sec=LOG_THROTTLE,
                    )
                    continue
                self.take_events(events)

    def take_events(self, events: list) -> None:
        """Publish and log what the link and the bridge did."""
        logger = self.get_logger()
        for event in events:
            if isinstance(event, SampleReceived):
                self.publish_sample(event)
            elif isinstance(event, Sent):
                self.applied_publisher.publish(fill(self.applied_message, event.openings))
            elif isinstance(event, Connected):
                self.on_connected(event)
            elif isinstance(event, LinkLost):
                logger.error(f'board link lost: {event.reason}: venting; reconnecting')
            elif isinstance(event, Vented) and not event.reason.startswith('link lost'):
                logger.warning(f'{event.reason}: venting')
            elif isinstance(event, Limited):
                logger.warning(
                    f'chambers {list(event.chambers)} at {list(event.pressures)} Pa, at or '
                    f'above max_pressure {self.bridge.settings.max_pressure:g} Pa: inlet '
                    'closed, outlet open',
                    throttle_duration_sec=LOG_THROTTLE,
                )
            elif isinstance(event, NoticeReceived):
                self.notices += 1
                code = event.notice.code
                name = NoticeCode(code).name if code in set(NoticeCode) else f'code {code}'
                logger.warning(
                    f'the board refused something: {name} (detail {event.notice.detail})',
                    throttle_duration_sec=LOG_THROTTLE,
                )

    def on_connected(self, event: Connected) -> None:
        capabilities = event.capabilities
        if capabilities.bend_sensors and self.joint_publisher is None:
            self.joint_publisher = self.create_publisher(JointState, JOINT_STATES, STREAM_QOS)
        firmware = '.'.join(map(str, capabilities.firmware))
        self.get_logger().info(
            f'board on {self.link.settings.port}: firmware {firmware}, '
            f'{capabilities.sample_rate_hz} Hz, {capabilities.bend_sensors} bend sensors'
            f'{"" if capabilities.bend_sensors else " (no joint_states)"}, watchdog '
            f'{capabilities.watchdog_ms} ms, vent pressure {capabilities.vent_pressure_pa} Pa '
            f'(session {self.link.sessions}: vented)'
        )

    def publish_sample(self, event: SampleReceived) -> None:
        """chamber_pressure, then joint_states (stamped with the board's reading time)."""
        sample = event.sample
        self.flags = sample.status
        self.pressure_publisher.publish(fill(self.pressure_message, sample.pressures_pa))
        if self.joint_publisher is None or not sample.angles:
            return
        stamp = self.host_clock.system_ns(event.stamp)
        message = self.joint_state
        message.header.stamp.sec, message.header.stamp.nanosec = divmod(stamp, 1_000_000_000)
        message.position = array('d', [angle * ANGLE_UNIT for angle in sample.angles])
        self.joint_publisher.publish(message)

    # -- the controller --------------------------------------------------------------------

    def on_command(self, message: Float64MultiArray) -> None:
        """Send valid openings (safety rules first), refuse the rest; publish those in force."""
        try:
            openings = valve_openings(message.data, VALVE_COMMAND)
        except InvalidInputError as error:
            self.reject(VALVE_COMMAND, error)
            with self.link_lock:  # the link thread fills the same message
                self.applied_publisher.publish(fill(self.applied_message, self.bridge.openings))
            return
        with self.link_lock:
            self.take_events(self.bridge.command(openings, time.monotonic()))

    # -- diagnostics and the end -----------------------------------------------------------

    def report(self) -> None:
        """One /diagnostics status: link state, frames, losses, round trip, board flags."""
        with self.link_lock:
            link, bridge = self.link, self.bridge
            counts = link.decoder.counts
            capabilities = link.capabilities
            trip = link.round_trip
            flags = ', '.join(flag.name for flag in Status if flag in self.flags) or 'none'
            values = {
                'port': link.settings.port,
                'link': link.state.value,
                'sessions': str(link.sessions),
                'samples': str(link.samples),
                'samples_lost': str(link.lost_samples),
                'frames_good': str(counts.good),
                'frames_bad': str(counts.bad + link.undecodable),
                'round_trip_ms': f'{trip.last * 1e3:.2f} last, {trip.mean * 1e3:.2f} mean, '
                f'{trip.largest * 1e3:.2f} max',
                'board_flags': flags if link.samples else 'none yet',
                'bend_sensors': str(capabilities.bend_sensors) if capabilities else 'unknown',
                'openings': ' '.join(f'{value:.4f}' for value in bridge.openings),
                'pressure_limited': str(bridge.limited),
                'vents': str(bridge.vents),
                'board_notices': str(self.notices),
            }
            if capabilities:
                values['firmware'] = '.'.join(map(str, capabilities.firmware))
                values['sample_rate_hz'] = str(capabilities.sample_rate_hz)
            streaming = link.state is LinkState.STREAMING
            error = link.last_error
        if not streaming:
            level = DiagnosticStatus.ERROR
            text = f'board link {values["link"]}: {error or "no answer yet"}; vented'
        elif self.flags:
            level, text = DiagnosticStatus.WARN, f'board flags {values["board_flags"]}'
        else:
            level, text = DiagnosticStatus.OK, 'streaming'
        self.publish_status(level, text, values)

    def on_shutdown(self) -> None:
        """Vent, then close the port (the link thread stopped first)."""
        self.stopping.set()
        self.thread.join(STOP_WAIT)
        with self.link_lock:
            sent = self.bridge.vent(time.monotonic(), 'stopping')
            delivered = any(isinstance(e, Sent) and e.delivered for e in sent)
            if delivered:
                time.sleep(VENT_FLUSH)
            self.link.close()
        self.get_logger().info(
            'vented and closed the port' if delivered else 'closed the port (no board to vent)'
        )


def main(args: list[str] | None = None) -> int:
    """Console script ``hardware`` (``ros2 run exodigit_nodes hardware``)."""
    return run(Hardware, args)


if __name__ == '__main__':
    raise SystemExit(main())
