"""The two ends of the link as state machines (docs/spec/hardware.md §4-§7), on the test's clock:
the board's handshake, watchdog, vents and refusals; the host's handshake, refusal of another
version, supervision of the samples, reconnection with backoff; the board clock's mapping; a
fuzz of the byte stream into both ends."""

import itertools
import math
import random

import pytest
from exodigit_nodes.hardware.board import VENT_DUTIES, BoardProtocol, default_capabilities
from exodigit_nodes.hardware.framing import FrameDecoder, encode_frame
from exodigit_nodes.hardware.link import (
    Connected,
    HostLink,
    IncompatibleBoardError,
    LinkLost,
    LinkSettings,
    LinkState,
    NoticeReceived,
    SampleReceived,
)
from exodigit_nodes.hardware.messages import (
    Capabilities,
    Heartbeat,
    Hello,
    Notice,
    NoticeCode,
    Openings,
    Sample,
    Status,
    decode,
    encode,
)
from exodigit_nodes.hardware.timing import BoardClock, HostClock
from hardware_loopback import LoopbackPort

OPEN = (10000, 0, 5000, 0, 0, 2500)


def frame(message) -> bytes:
    return encode_frame(encode(message))


def answers(data: bytes) -> list:
    return [decode(p) for p in FrameDecoder().feed(data)]


# -- the board ---------------------------------------------------------------------------------


def streaming_board(now=0.0) -> BoardProtocol:
    board = BoardProtocol(default_capabilities())
    assert answers(board.receive(frame(Hello(1)), now)) == [default_capabilities()]
    return board


def test_a_board_is_silent_and_vented_until_a_hello_of_its_version():
    board = BoardProtocol(default_capabilities())
    assert board.duties(0.0) == VENT_DUTIES
    assert board.sample(0.0, (0, 0, 0)) == b''
    assert answers(board.receive(frame(Openings(1, OPEN)), 0.0)) == [
        Notice(NoticeCode.NOT_STREAMING, 0x02)
    ]
    assert board.duties(0.01) == VENT_DUTIES
    # another version: the capabilities (so the host can tell), and still silent
    assert answers(board.receive(frame(Hello(2)), 0.02)) == [default_capabilities()]
    assert not board.streaming and board.sample(0.03, (0, 0, 0)) == b''


def test_a_streaming_board_applies_openings_from_the_next_sample_and_echoes_them():
    board = streaming_board()
    (first,) = answers(board.sample(0.01, (0, 0, 0), (0, 0, 0)))
    assert first.sequence == 0 and first.applied_sequence == 0 and first.status == Status(0)
    assert board.duties(0.01) == VENT_DUTIES  # vented by the hello
    board.receive(frame(Openings(7, OPEN)), 0.015)
    assert board.duties(0.02) == OPEN
    (second,) = answers(board.sample(0.02, (100, 200, 300), (1, 2, 3)))
    assert second.sequence == 1 and second.applied_sequence == 7
    assert second.pressures_pa == (100, 200, 300) and second.angles == (1, 2, 3)
    assert second.board_time_us == 20000


def test_the_watchdog_vents_until_the_next_openings_not_a_heartbeat():
    board = streaming_board()
    board.receive(frame(Openings(1, OPEN)), 0.0)
    assert board.duties(0.2) == OPEN  # 200 ms: not more than the watchdog time yet
    assert board.duties(0.2001) == VENT_DUTIES
    (sample,) = answers(board.sample(0.21, (0, 0, 0), (0, 0, 0)))
    assert sample.status & Status.WATCHDOG_VENT
    board.receive(frame(Heartbeat()), 0.22)
    assert board.duties(0.23) == VENT_DUTIES
    board.receive(frame(Openings(2, OPEN)), 0.24)
    assert board.duties(0.25) == OPEN
    (sample,) = answers(board.sample(0.25, (0, 0, 0), (0, 0, 0)))
    assert not sample.status & Status.WATCHDOG_VENT


def test_heartbeats_keep_the_openings():
    board = streaming_board()
    board.receive(frame(Openings(1, OPEN)), 0.0)
    for k in range(1, 20):
        board.receive(frame(Heartbeat()), 0.15 * k)
    assert board.duties(0.15 * 19 + 0.1) == OPEN


def test_a_chamber_at_the_vent_pressure_is_vented_alone():
    board = streaming_board()
    board.receive(frame(Openings(1, (10000, 10000, 10000, 0, 0, 0))), 0.0)
    (sample,) = answers(board.sample(0.01, (149_999, 150_000, 0), (0, 0, 0)))
    assert sample.status & Status.OVER_PRESSURE
    assert board.duties(0.01) == (10000, 0, 10000, 0, 10000, 0)
    (sample,) = answers(board.sample(0.02, (0, 0, 0), (0, 0, 0)))
    assert not sample.status & Status.OVER_PRESSURE
    assert board.duties(0.02) == (10000, 10000, 10000, 0, 0, 0)


def test_a_duty_above_full_is_refused_and_the_openings_before_kept():
    board = streaming_board()
    board.receive(frame(Openings(1, OPEN)), 0.0)
    bad = (0, 0, 10001, 0, 0, 0)
    assert answers(board.receive(frame(Openings(2, bad)), 0.01)) == [
        Notice(NoticeCode.BAD_OPENINGS, 2)
    ]
    assert board.duties(0.02) == OPEN
    (sample,) = answers(board.sample(0.02, (0, 0, 0), (0, 0, 0)))
    assert sample.status & Status.COMMAND_REFUSED and sample.applied_sequence == 1


def test_bad_frames_and_unknown_messages_are_answered_and_change_nothing():
    board = streaming_board()
    board.receive(frame(Openings(1, OPEN)), 0.0)
    assert answers(board.receive(encode_frame(b'\x42\x00'), 0.05)) == [
        Notice(NoticeCode.UNKNOWN_TYPE, 0x42)
    ]
    assert answers(board.receive(encode_frame(b'\x02\x00'), 0.06)) == [
        Notice(NoticeCode.BAD_LENGTH, 0x02)
    ]
    assert board.receive(b'\x01\x02\x03\x00', 0.07) == b''  # bad stuffing/CRC: dropped
    (sample,) = answers(board.sample(0.08, (0, 0, 0), (0, 0, 0)))
    assert sample.status & Status.RECEIVE_ERRORS
    (sample,) = answers(board.sample(0.09, (0, 0, 0), (0, 0, 0)))
    assert not sample.status & Status.RECEIVE_ERRORS
    assert board.duties(0.1) == OPEN
    # none of them fed the watchdog
    assert board.duties(0.2001) == VENT_DUTIES


# -- the host ----------------------------------------------------------------------------------


def host(port: LoopbackPort, **settings) -> HostLink:
    return HostLink(LinkSettings(port='loop', **settings), opener=port.opener)


def connect(port: LoopbackPort, link: HostLink) -> Capabilities:
    (event,) = link.poll(port.now)
    assert isinstance(event, Connected)
    return event.capabilities


def test_the_host_opens_says_hello_and_streams():
    port = LoopbackPort()
    link = host(port)
    assert connect(port, link) == default_capabilities()
    assert link.state is LinkState.STREAMING and link.sessions == 1
    port.now = 0.01
    port.sample((1000, 2000, 3000), (10, 20, 30))
    (event,) = link.poll(port.now)
    assert isinstance(event, SampleReceived)
    assert event.sample.pressures_pa == (1000, 2000, 3000) and event.lost == 0
    assert event.stamp <= event.received


def test_the_host_refuses_another_version_in_one_line():
    port = LoopbackPort(BoardProtocol(default_capabilities(version=2)))
    link = host(port)
    with pytest.raises(IncompatibleBoardError) as refused:
        link.poll(0.0)
    text = str(refused.value)
    assert '\n' not in text and 'version 2' in text and 'version 1' in text
    assert link.state is LinkState.DISCONNECTED


@pytest.mark.parametrize('shape', [{'chambers': 2}, {'bend_sensors': 1}, {'sample_rate_hz': 0}])
def test_the_host_refuses_a_board_of_another_shape(shape):
    port = LoopbackPort(BoardProtocol(default_capabilities(**shape)))
    with pytest.raises(IncompatibleBoardError):
        host(port).poll(0.0)


def test_openings_are_sent_only_while_streaming_and_their_round_trip_measured():
    port = LoopbackPort()
    link = host(port)
    assert link.send_openings(OPEN, 0.0) is None  # not yet connected: nothing written
    connect(port, link)
    port.now = 0.004
    sequence = link.send_openings(OPEN, port.now)
    assert sequence == 1 and port.board.commanded == OPEN
    port.now = 0.01
    port.sample()
    link.poll(port.now)
    assert link.round_trip.last == pytest.approx(0.006)


def test_sequence_gaps_count_as_lost_samples():
    port = LoopbackPort()
    link = host(port)
    connect(port, link)
    for k in range(10):
        port.now = 0.01 * (k + 1)
        port.sample()
        if k in (3, 4, 7):
            port.inbox.clear()  # the line ate them
        link.poll(port.now)
    assert link.lost_samples == 3 and link.samples == 7


def test_samples_that_stop_lose_the_link_and_the_host_says_hello_until_answered():
    port = LoopbackPort()
    link = host(port, sample_timeout=0.1, hello_interval=0.25)
    connect(port, link)
    port.now = 0.05
    port.sample()
    link.poll(port.now)
    port.board.streaming = False  # the board stops talking (stuck, or reset and silent)
    hellos = port.written.count(frame(Hello(1)))
    port.now = 0.151
    (event,) = link.poll(port.now)
    assert isinstance(event, LinkLost) and link.state is LinkState.SILENT
    assert 'no valid sample for 0.1 s' in event.reason
    # the hello went at once: the board (it answers every hello) starts a new session
    assert port.written.count(frame(Hello(1))) == hellos + 1
    (event,) = link.poll(port.now + 0.001)
    assert isinstance(event, Connected) and link.state is LinkState.STREAMING
    assert link.sessions == 2


def test_heartbeats_go_when_nothing_else_does():
    port = LoopbackPort()
    link = host(port, heartbeat_period=0.05, sample_timeout=10.0)
    connect(port, link)
    for k in range(1, 41):
        port.now = 0.01 * k
        link.poll(port.now)
    beats = port.written.count(frame(Heartbeat()))
    assert 7 <= beats <= 8  # one per 50 ms of 0.4 s
    assert not port.board.watchdog_tripped


def test_an_unplugged_port_is_reopened_with_doubling_backoff_then_a_new_session():
    port = LoopbackPort()
    link = host(port, reconnect_min=0.1, reconnect_max=0.4)
    connect(port, link)
    port.plugged = False
    port.now = 0.01
    (event,) = link.poll(port.now)
    assert isinstance(event, LinkLost) and event.state is LinkState.DISCONNECTED
    attempts = []
    for k in range(2, 200):
        port.now = 0.01 * k
        before = link.failures
        link.poll(port.now)
        if link.failures != before:
            attempts.append(round(port.now, 2))
    gaps = [round(b - a, 2) for a, b in itertools.pairwise(attempts)]
    assert gaps[:3] == [0.2, 0.4, 0.4]  # 0.1, 0.2, 0.4, then capped at 0.4
    port.plugged = True
    port.board.reset()  # the board lost power with the cable
    events = []
    for k in range(200, 260):
        port.now = 0.01 * k
        events += link.poll(port.now)
    assert any(isinstance(e, Connected) for e in events)
    assert link.state is LinkState.STREAMING and port.board.duties(port.now) == VENT_DUTIES


def test_no_answer_within_the_handshake_timeout_closes_and_retries():
    port = LoopbackPort()
    port.board.receive = lambda data, now: b''  # a mute device on the port
    link = host(port, handshake_timeout=0.5)
    link.poll(0.0)
    assert link.state is LinkState.HANDSHAKE
    for k in range(1, 52):
        link.poll(0.01 * k)
    assert link.state is LinkState.DISCONNECTED and 'no answer to hello' in link.last_error
    assert port.written.count(frame(Hello(1))) == 3  # at 0, 0.25 and 0.5 s


def test_notices_are_handed_on():
    port = LoopbackPort()
    link = host(port)
    connect(port, link)
    port.inbox += frame(Notice(NoticeCode.BAD_OPENINGS, 4))
    (event,) = link.poll(0.001)
    assert event == NoticeReceived(Notice(NoticeCode.BAD_OPENINGS, 4))


# -- the board clock ---------------------------------------------------------------------------


def test_the_board_clock_takes_the_least_delayed_sample_and_follows_wraps():
    clock = BoardClock()
    # board time 0 at host 100.0; delays 5, 1, 3 ms
    assert clock.host_time(0, 100.005) == pytest.approx(100.005)
    assert clock.host_time(10_000, 100.011) == pytest.approx(100.011)
    assert clock.host_time(20_000, 100.023) == pytest.approx(100.021, abs=1e-5)
    # the u32 µs counter wraps: 2**32 µs later (one sample: its own delay is all it knows)
    wrapped = (20_000 + 2**32 - 1_000) % 2**32
    read = 100.021 + (2**32 - 1_000) * 1e-6
    assert read <= clock.host_time(wrapped, read + 0.002) <= read + 0.002 + 1e-9
    # the next samples, each 1 ms delayed, pull it to 1 ms (within the drift allowed)
    for k in range(1, 5):
        board = (wrapped + k * 10_000) % 2**32
        stamp = clock.host_time(board, read + k * 0.01 + 0.001)
    assert stamp == pytest.approx(read + 0.04 + 0.001, abs=1e-5)


def test_stamps_never_go_back_and_catch_up_with_a_lower_offset():
    clock = BoardClock()
    # samples 10 ms apart on the board; the host, busy, reads the first five at once at 50 ms,
    # then each 1 ms after it was taken
    arrivals = [0.050] * 5 + [0.010 * k + 0.001 for k in range(5, 30)]
    stamps = [clock.host_time(10_000 * k, arrivals[k]) for k in range(30)]
    assert all(b >= a for a, b in itertools.pairwise(stamps))
    assert all(b > a for a, b in itertools.pairwise(stamps[5:]))
    assert all(stamp <= arrival for stamp, arrival in zip(stamps, arrivals, strict=True))
    assert stamps[-1] == pytest.approx(0.29 + 0.001, abs=1e-5)  # on the least delay again


SYSTEM_OFFSET = 1_765_000_000 * 10**9
"""System clock − monotonic clock of the fake host, ns."""


def host_clock(reads: list[int]) -> HostClock:
    """A HostClock whose monotonic and system clocks return ``reads`` in turn (it reads both)."""
    scripted = iter(reads)
    return HostClock(lambda: next(scripted), lambda: next(scripted))


def reads_of(samples: int, offset, preempted=()) -> list[int]:
    """Per sample k (read 2 ms after its monotonic time k × 10 ms): monotonic, system, monotonic.

    ``offset(k)``: the system clock's offset then; ``preempted``: samples whose thread lost 30 ms
    between its first monotonic read and its system read.
    """
    reads = []
    for k in range(samples):
        read = k * 10_000_000 + 2_000_000
        late = 30_000_000 if k in preempted else 0
        reads += [read, read + late + offset(k), read + late]
    return reads


def test_host_stamps_keep_the_monotonic_pace_when_the_reading_thread_is_preempted():
    # the system clock read 30 ms late at samples 3 and 4: read per sample, the offset would put
    # sample 3 at 40 ms and sample 5 at 50 ms, after sample 4's 70 ms
    clock = host_clock(reads_of(8, lambda k: SYSTEM_OFFSET, preempted={3, 4}))
    stamps = [clock.system_ns(k * 0.010) for k in range(8)]
    assert stamps == [k * 10_000_000 + SYSTEM_OFFSET for k in range(8)]


def test_host_stamps_follow_the_system_clock_when_it_is_set():
    # the system clock set back 1 s before sample 5, whose read is preempted: sample 6 follows
    def offset(k):
        return SYSTEM_OFFSET - (10**9 if k >= 5 else 0)

    clock = host_clock(reads_of(8, offset, preempted={5}))
    stamps = [clock.system_ns(k * 0.010) for k in range(8)]
    assert stamps[:6] == [k * 10_000_000 + SYSTEM_OFFSET for k in range(6)]
    assert stamps[6:] == [k * 10_000_000 + offset(k) for k in (6, 7)]


# -- fuzz --------------------------------------------------------------------------------------


def test_a_fuzzed_stream_never_breaks_either_end_and_the_board_vents_when_starved():
    rng = random.Random(3601)
    port = LoopbackPort()
    link = host(port, sample_timeout=0.05)
    connect(port, link)
    good = [
        frame(Openings(1, OPEN)),
        frame(Heartbeat()),
        frame(Sample(5, 1000, Status(0), 1, (1, 2, 3), (4, 5, 6))),
        frame(Hello(1)),
    ]
    board = port.board
    for step in range(5000):
        port.now = step * 0.001
        choice = rng.random()
        if choice < 0.4:
            data = bytes(rng.randrange(256) for _ in range(rng.randrange(1, 80)))
        else:
            data = bytearray(rng.choice(good))
            for _ in range(rng.randrange(3)):
                data[rng.randrange(len(data))] = rng.randrange(256)
            data = bytes(data)
        board.receive(data, port.now)  # the board gets noise ...
        port.inbox += data  # ... and so does the host
        events = link.poll(port.now)
        for event in events:
            if isinstance(event, SampleReceived):
                assert all(math.isfinite(p) for p in event.sample.pressures_pa)
        duties = board.duties(port.now)
        assert all(0 <= d <= 10000 for d in duties)
        if board.last_valid is not None and port.now - board.last_valid > 0.2:
            assert duties == VENT_DUTIES
    assert link.decoder.counts.bad > 1000 and board.decoder.counts.bad > 1000
