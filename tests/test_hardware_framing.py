"""The link's frames and messages (docs/spec/hardware.md §2-§3): CRC check values against an
independent bitwise CRC, COBS against a reference written from the algorithm's definition, the
spec's example frames, round trips of every message, and refusals of every malformed input."""

import contextlib
import random
import re
from pathlib import Path

import pytest
from exodigit_nodes.hardware.board import default_capabilities
from exodigit_nodes.hardware.framing import (
    MAX_FRAME,
    MAX_PAYLOAD,
    FrameDecoder,
    crc16,
    encode_frame,
)
from exodigit_nodes.hardware.messages import (
    LAYOUTS,
    Capabilities,
    Heartbeat,
    Hello,
    MessageType,
    Notice,
    Openings,
    ProtocolError,
    Sample,
    Status,
    decode,
    duties_of,
    encode,
    openings_of,
)
from hypothesis import given, settings
from hypothesis import strategies as st

UNTIMED = settings(deadline=None)
"""Hypothesis without its 200 ms deadline: no timing asserts (a shared machine stalls a case)."""
SPEC = Path(__file__).resolve().parents[1] / 'docs' / 'spec' / 'hardware.md'


def reference_crc(data: bytes) -> int:
    """CRC-16/CCITT-FALSE bit by bit from its definition (poly 0x1021, init 0xFFFF, MSB first)."""
    register = 0xFFFF
    for byte in data:
        for bit in range(7, -1, -1):
            feedback = ((register >> 15) & 1) ^ ((byte >> bit) & 1)
            register = (register << 1) & 0xFFFF
            if feedback:
                register ^= 0x1021
    return register


def reference_cobs(data: bytes) -> bytes:
    """COBS from its definition: each block is a code byte (distance to the next zero, at most
    255 meaning 254 data bytes and no zero) and the non-zero bytes before that zero; a full
    block that ends the data is the last."""
    out = bytearray()
    block = bytearray()
    for index, byte in enumerate(data):
        if byte == 0:
            out += bytes([len(block) + 1]) + block
            block.clear()
        else:
            block.append(byte)
            if len(block) == 254 and index + 1 < len(data):
                out += b'\xff' + block
                block.clear()
    out += bytes([len(block) + 1]) + block
    return bytes(out)


def test_crc_check_values():
    assert crc16(b'123456789') == 0x29B1  # the catalogued check value of CRC-16/CCITT-FALSE
    assert crc16(b'') == 0xFFFF
    assert reference_crc(b'123456789') == 0x29B1


@UNTIMED
@given(st.binary(max_size=80))
def test_crc_equals_the_bitwise_definition(data):
    assert crc16(data) == reference_crc(data)


@UNTIMED
@given(st.binary(min_size=1, max_size=MAX_PAYLOAD))
def test_a_frame_is_the_stuffed_payload_and_crc_then_one_zero(payload):
    frame = encode_frame(payload)
    checked = payload + reference_crc(payload).to_bytes(2, 'little')
    assert frame == reference_cobs(checked) + b'\x00'
    assert frame.count(0) == 1 and len(frame) <= MAX_FRAME + 1
    decoder = FrameDecoder()
    assert decoder.feed(frame) == [payload]
    assert decoder.counts.good == 1 and decoder.counts.bad == 0


def test_payloads_outside_the_size_limits_are_refused():
    with pytest.raises(ValueError, match='1 to 64 bytes'):
        encode_frame(b'')
    with pytest.raises(ValueError, match='65 bytes'):
        encode_frame(bytes(MAX_PAYLOAD + 1))


def spec_examples() -> list[tuple[str, bytes, bytes | None]]:
    """The example block of the spec: (name, payload or None, frame)."""
    text = SPEC.read_text()
    block = text[text.index('Examples (hex') :].split('```')[1]
    rows = re.findall(r'(\w+)[^\n]*?(?:payload ([0-9a-f ]+?))?\s+frame ([0-9a-f ]+)', block)
    return [
        (name, bytes.fromhex(payload) if payload else None, bytes.fromhex(frame))
        for name, payload, frame in rows
    ]


def test_the_spec_example_frames_are_what_the_code_sends():
    examples = {name: (payload, frame) for name, payload, frame in spec_examples()}
    assert sorted(examples) == ['HEARTBEAT', 'HELLO', 'OPENINGS']
    assert encode_frame(encode(Hello(1))) == examples['HELLO'][1]
    assert encode(Hello(1)) == examples['HELLO'][0]
    assert encode_frame(encode(Heartbeat())) == examples['HEARTBEAT'][1]
    openings = Openings(1, (10000, 0, 5000, 0, 10000, 0))
    assert encode_frame(encode(openings)) == examples['OPENINGS'][1]


def test_the_spec_gives_each_body_its_length():
    text = SPEC.read_text()
    assert '| 0x02 | OPENINGS |' in text and LAYOUTS[MessageType.OPENINGS].size == 14
    assert LAYOUTS[MessageType.CAPABILITIES].size == 29 and '| 29 |' in text
    assert LAYOUTS[MessageType.SAMPLE].size == 22 and '22, or 28 with bend angles' in text


u16 = st.integers(0, 0xFFFF)
i32 = st.integers(-(2**31), 2**31 - 1)
i16 = st.integers(-(2**15), 2**15 - 1)
u8 = st.integers(0, 255)
messages = st.one_of(
    st.builds(Hello, u8),
    st.builds(Openings, u16, st.tuples(*[u16] * 6)),
    st.just(Heartbeat()),
    st.builds(
        Capabilities,
        u8,
        st.tuples(u8, u8, u8),
        u8,
        u8,
        u16,
        u16,
        u16,
        i32,
        i32,
        i32,
        u16,
        st.booleans(),
        u16,
    ),
    st.builds(
        Sample,
        u16,
        st.integers(0, 2**32 - 1),
        st.builds(Status, st.integers(0, 0x3F)),
        u16,
        st.tuples(i32, i32, i32),
        st.one_of(st.just(()), st.tuples(i16, i16, i16)),
    ),
    st.builds(Notice, u8, u8),
)


@UNTIMED
@given(messages)
def test_every_message_survives_encoding_framing_and_decoding(message):
    (payload,) = FrameDecoder().feed(encode_frame(encode(message)))
    assert decode(payload) == message


def test_the_capabilities_body_has_the_spec_offsets():
    body = encode(default_capabilities())[1:]
    assert body[0] == 1 and body[4] == 3 and body[5] == 3
    assert int.from_bytes(body[6:8], 'little') == 100  # sample rate
    assert int.from_bytes(body[8:10], 'little') == 200  # watchdog, ms
    assert int.from_bytes(body[20:24], 'little', signed=True) == 150_000  # vent pressure
    assert body[26] == 1 and int.from_bytes(body[27:29], 'little') == 1000


def test_a_sample_body_has_the_spec_offsets():
    sample = Sample(7, 123456, Status.OVER_PRESSURE, 9, (-1, 20000, 3), (1, -2, 3))
    body = encode(sample)[1:]
    assert int.from_bytes(body[2:6], 'little') == 123456
    assert int.from_bytes(body[6:8], 'little') == 2
    assert int.from_bytes(body[10:14], 'little', signed=True) == -1
    assert int.from_bytes(body[24:26], 'little', signed=True) == -2


@pytest.mark.parametrize(
    ('payload', 'reason'),
    [
        (b'', 'empty'),
        (b'\x7f', 'unknown message type 0x7f'),
        (b'\x01', 'HELLO of 0 bytes'),
        (b'\x01\x01\x00', 'HELLO of 2 bytes'),
        (b'\x02' + bytes(13), 'OPENINGS of 13 bytes'),
        (b'\x82' + bytes(25), 'SAMPLE of 25 bytes: its body has 22 bytes or 28'),
        (b'\x03\x00', 'HEARTBEAT of 1 bytes'),
    ],
)
def test_payloads_of_no_message_are_refused_with_the_reason(payload, reason):
    with pytest.raises(ProtocolError, match=reason):
        decode(payload)


def test_fields_that_do_not_fit_their_wire_type_are_refused():
    with pytest.raises(ValueError, match='OPENINGS: a field does not fit'):
        encode(Openings(1, (70000, 0, 0, 0, 0, 0)))
    with pytest.raises(ValueError, match='HELLO'):
        encode(Hello(256))


def test_openings_round_trip_to_the_nearest_ten_thousandth():
    openings = [0.0, 0.12345, 0.5, 1.0, 0.99995, 1e-5]
    duties = duties_of(openings)
    assert duties == (0, 1234, 5000, 10000, 10000, 0)
    assert (
        max(abs(a - b) for a, b in zip(openings_of(duties), openings, strict=True)) <= 5e-5 + 1e-12
    )


# -- the decoder on damaged streams ------------------------------------------------------------


def test_a_wrong_checksum_is_dropped_and_counted():
    frame = bytearray(encode_frame(encode(Hello(1))))
    frame[2] ^= 0x10  # a payload bit, still no zero
    decoder = FrameDecoder()
    assert decoder.feed(bytes(frame)) == []
    assert decoder.counts.bad_checksum == 1
    assert decoder.feed(encode_frame(b'\x03')) == [b'\x03']  # the next frame is whole


def test_a_truncated_frame_costs_that_frame_only():
    good = encode_frame(encode(Heartbeat()))
    cut = encode_frame(encode(Openings(5, (1, 2, 3, 4, 5, 6))))[:-4]
    decoder = FrameDecoder()
    # the cut frame runs into the next frame's bytes up to its delimiter: both are lost
    assert decoder.feed(cut + good + good) == [b'\x03']
    assert decoder.counts.good == 1 and decoder.counts.bad == 1


def test_a_receiver_that_joins_mid_frame_is_in_step_after_the_next_zero():
    frames = b''.join(encode_frame(encode(Notice(1, i))) for i in range(5))
    decoder = FrameDecoder()
    payloads = decoder.feed(frames[3:])
    assert [decode(p) for p in payloads] == [Notice(1, i) for i in range(1, 5)]


def test_a_run_without_a_delimiter_is_dropped_up_to_the_next_zero():
    decoder = FrameDecoder()
    assert decoder.feed(b'\x01' * (MAX_FRAME + 10)) == []
    assert decoder.feed(b'\x01' * 500 + b'\x00' + encode_frame(b'\x03')) == [b'\x03']
    assert decoder.counts.overlong == 1


@UNTIMED
@given(st.lists(messages, min_size=1, max_size=8), st.data())
def test_frames_split_anywhere_across_reads_all_arrive(sent, data):
    stream = b'\x00' + b''.join(encode_frame(encode(m)) for m in sent)
    cuts = sorted(data.draw(st.lists(st.integers(0, len(stream)), max_size=10)))
    decoder = FrameDecoder()
    received = []
    for start, end in zip([0, *cuts], [*cuts, len(stream)], strict=True):
        received += decoder.feed(stream[start:end])
    assert [decode(p) for p in received] == sent


def test_thousands_of_random_and_mutated_frames_never_raise_and_lose_no_good_frame():
    rng = random.Random(36)
    decoder = FrameDecoder()
    proper = [
        encode(Hello(1)),
        encode(Openings(3, (1, 2, 3, 4, 5, 6))),
        encode(Sample(1, 2, Status(0), 3, (4, 5, 6), (7, 8, 9))),
        encode(default_capabilities()),
    ]
    good_sent = 0
    decoded = 0
    for _ in range(5000):
        kind = rng.random()
        payload = rng.choice(proper)
        frame = bytearray(encode_frame(payload))
        if kind < 0.25:  # random bytes
            chunk = bytes(rng.randrange(256) for _ in range(rng.randrange(1, 90)))
        elif kind < 0.5:  # a bit flipped
            index = rng.randrange(len(frame))
            frame[index] ^= 1 << rng.randrange(8)
            chunk = bytes(frame)
        elif kind < 0.65:  # a byte lost
            del frame[rng.randrange(len(frame))]
            chunk = bytes(frame)
        elif kind < 0.75:  # a random payload, properly framed
            chunk = encode_frame(bytes(rng.randrange(256) for _ in range(rng.randrange(1, 65))))
        else:  # a good frame after a delimiter (so damage before it cannot take it along)
            chunk = b'\x00' + bytes(frame)
            good_sent += 1
        for payload in decoder.feed(chunk):
            decoded += 1
            with contextlib.suppress(ProtocolError):
                decode(payload)
    assert decoder.counts.good == decoded
    assert decoder.counts.good >= good_sent  # damaged frames may still be good by chance
    assert decoder.counts.bad > 1000
