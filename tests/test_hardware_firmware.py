"""The reference firmware's protocol core (firmware/exodigit_board/src/link/exo_link.c), built on
this host with its C compiler and driven through ctypes, against the Python side: the same CRC,
COBS and frames, and the same board (answers, duties, samples) for the same bytes at the same
times, including thousands of random and damaged frames. Without a C compiler these tests are
skipped, saying so (not counted as passing)."""

import ctypes
import random
import shutil
import subprocess
from pathlib import Path

import pytest
from cobs import cobs
from exodigit_nodes.hardware.board import BoardProtocol, default_capabilities
from exodigit_nodes.hardware.framing import MAX_PAYLOAD, crc16, encode_frame
from exodigit_nodes.hardware.link import Connected, HostLink, LinkSettings, SampleReceived
from exodigit_nodes.hardware.messages import (
    Heartbeat,
    Hello,
    Openings,
    Sample,
    Status,
    encode,
)

CORE = Path(__file__).resolve().parents[1] / 'firmware' / 'exodigit_board' / 'src' / 'link'
VALVES = 6
FRAME = 68
SUPPLY_LOW, SENSOR_FAULT = 0x0004, 0x0008


class Capabilities(ctypes.Structure):
    """exo_capabilities, field by field (ctypes lays it out as the C compiler does)."""

    _fields_ = [
        ('version', ctypes.c_uint8),
        ('firmware', ctypes.c_uint8 * 3),
        ('chambers', ctypes.c_uint8),
        ('bend_sensors', ctypes.c_uint8),
        ('sample_rate_hz', ctypes.c_uint16),
        ('watchdog_ms', ctypes.c_uint16),
        ('pressure_quantum_pa', ctypes.c_uint16),
        ('pressure_min_pa', ctypes.c_int32),
        ('pressure_max_pa', ctypes.c_int32),
        ('vent_pressure_pa', ctypes.c_int32),
        ('angle_quantum', ctypes.c_uint16),
        ('proportional_valves', ctypes.c_uint8),
        ('pwm_hz', ctypes.c_uint16),
    ]


@pytest.fixture(scope='module')
def core(tmp_path_factory):
    compiler = shutil.which('cc') or shutil.which('gcc') or shutil.which('clang')
    if compiler is None:
        pytest.skip('no C compiler on this machine: the firmware core is not built or tested')
    library = tmp_path_factory.mktemp('firmware') / 'libexo_link.so'
    subprocess.run(
        [compiler, '-std=c99', '-O2', '-Wall', '-Wextra', '-Wconversion', '-Werror',
         '-pedantic', '-shared', '-fPIC', '-o', str(library), str(CORE / 'exo_link.c')],
        check=True,
        capture_output=True,
        text=True,
    )  # fmt: skip
    lib = ctypes.CDLL(str(library))
    lib.exo_crc16.restype = ctypes.c_uint16
    lib.exo_crc16.argtypes = [ctypes.c_char_p, ctypes.c_size_t]
    for name in ('exo_cobs_encode', 'exo_cobs_decode', 'exo_frame'):
        getattr(lib, name).restype = ctypes.c_size_t
        getattr(lib, name).argtypes = [ctypes.c_char_p, ctypes.c_size_t, ctypes.c_char_p]
    lib.exo_board_receive.restype = ctypes.c_size_t
    lib.exo_board_receive.argtypes = [
        ctypes.c_void_p, ctypes.c_uint8, ctypes.c_uint32, ctypes.c_char_p
    ]  # fmt: skip
    lib.exo_board_duties.argtypes = [ctypes.c_void_p, ctypes.c_uint32, ctypes.c_void_p]
    lib.exo_board_sample.restype = ctypes.c_size_t
    lib.exo_board_sample.argtypes = [
        ctypes.c_void_p, ctypes.c_uint32, ctypes.c_void_p, ctypes.c_void_p, ctypes.c_uint16,
        ctypes.c_char_p,
    ]  # fmt: skip
    return lib


class CBoard:
    """The C board, with the interface of :class:`exodigit_nodes.hardware.board.BoardProtocol`
    in integer microseconds."""

    def __init__(self, core, capabilities) -> None:
        self.core = core
        self.state = ctypes.create_string_buffer(1024)  # larger than exo_board
        fields = {
            name: getattr(capabilities, name)
            for name, _ in Capabilities._fields_
            if name != 'firmware'
        }
        fields['proportional_valves'] = int(fields['proportional_valves'])
        c_caps = Capabilities(**fields)
        c_caps.firmware[:] = capabilities.firmware
        core.exo_board_init(self.state, ctypes.byref(c_caps))
        self.bend = capabilities.bend_sensors

    def receive(self, data: bytes, now_us: int) -> bytes:
        answer = ctypes.create_string_buffer(FRAME)
        out = b''
        for byte in data:
            length = self.core.exo_board_receive(self.state, byte, now_us, answer)
            out += answer.raw[:length]
        return out

    def duties(self, now_us: int) -> tuple[int, ...]:
        duties = (ctypes.c_uint16 * VALVES)()
        self.core.exo_board_duties(self.state, now_us, duties)
        return tuple(duties)

    def sample(self, now_us, pressures, angles=(), flags=0) -> bytes:
        out = ctypes.create_string_buffer(FRAME)
        c_pressures = (ctypes.c_int32 * 3)(*pressures)
        c_angles = (ctypes.c_int16 * 3)(*angles) if angles else None
        length = self.core.exo_board_sample(self.state, now_us, c_pressures, c_angles, flags, out)
        return out.raw[:length]


def test_the_c_crc_is_the_python_crc(core):
    assert core.exo_crc16(b'123456789', 9) == 0x29B1
    rng = random.Random(1)
    for _ in range(2000):
        data = bytes(rng.randrange(256) for _ in range(rng.randrange(0, 80)))
        assert core.exo_crc16(data, len(data)) == crc16(data)


def test_the_c_cobs_is_the_cobs_library(core):
    rng = random.Random(2)
    for _ in range(3000):
        length = rng.randrange(0, 300)
        weights = rng.choice([0.0, 0.1, 0.5])
        data = bytes(0 if rng.random() < weights else rng.randrange(1, 256) for _ in range(length))
        out = ctypes.create_string_buffer(length + length // 254 + 2)
        written = core.exo_cobs_encode(data, length, out)  # before out.raw is read
        stuffed = out.raw[:written]
        assert stuffed == cobs.encode(data)
        back = ctypes.create_string_buffer(len(stuffed) + 1)
        written = core.exo_cobs_decode(stuffed, len(stuffed), back)
        assert back.raw[:written] == data


def test_the_c_cobs_decoder_refuses_what_the_library_refuses(core):
    rng = random.Random(3)
    invalid = ctypes.c_size_t(-1).value
    for _ in range(5000):
        run = bytes(rng.randrange(1, 256) for _ in range(rng.randrange(1, 40)))
        out = ctypes.create_string_buffer(64)
        length = core.exo_cobs_decode(run, len(run), out)
        try:
            expected = cobs.decode(run)
        except cobs.DecodeError:
            assert length == invalid, run.hex()
        else:
            assert out.raw[:length] == expected, run.hex()


def test_the_c_frames_are_the_python_frames(core):
    rng = random.Random(4)
    out = ctypes.create_string_buffer(FRAME)
    for _ in range(2000):
        payload = bytes(rng.randrange(256) for _ in range(rng.randrange(1, MAX_PAYLOAD + 1)))
        written = core.exo_frame(payload, len(payload), out)
        assert out.raw[:written] == encode_frame(payload)
    assert core.exo_frame(b'', 0, out) == 0
    assert core.exo_frame(bytes(65), 65, out) == 0


@pytest.mark.parametrize('bend', [3, 0], ids=['bend sensors', 'none'])
def test_the_c_board_answers_and_samples_as_the_python_board(core, bend):
    capabilities = default_capabilities(bend_sensors=bend, angle_quantum=10 if bend else 0)
    c_board = CBoard(core, capabilities)
    py_board = BoardProtocol(capabilities)
    rng = random.Random(36 + bend)
    good = [
        encode_frame(encode(Hello(1))),
        encode_frame(encode(Hello(2))),
        encode_frame(encode(Heartbeat())),
        encode_frame(encode(Openings(7, (10000, 0, 5000, 0, 10000, 0)))),
        encode_frame(encode(Openings(8, (1, 2, 3, 4, 5, 10001)))),
        encode_frame(encode(Sample(1, 2, Status(0), 3, (4, 5, 6)))),
        encode_frame(b'\x02\x00\x00'),
        encode_frame(b'\x55'),
    ]
    now_us = 0
    answers = samples = 0
    for step in range(4000):
        now_us += rng.choice([100, 1000, 10_000, 250_000])
        choice = rng.random()
        if choice < 0.5:
            data = rng.choice(good)
        elif choice < 0.7:
            data = bytearray(rng.choice(good))
            data[rng.randrange(len(data))] = rng.randrange(256)
            data = bytes(data)
        else:
            data = bytes(rng.randrange(256) for _ in range(rng.randrange(1, 90)))
        c_answer = c_board.receive(data, now_us)
        assert c_answer == py_board.receive(data, now_us * 1e-6), step
        answers += bool(c_answer)
        assert c_board.duties(now_us) == py_board.duties(now_us * 1e-6), step
        if step % 3 == 0:
            pressures = tuple(rng.choice([0, 1000, 149_999, 150_000, -5]) for _ in range(3))
            angles = tuple(rng.randrange(-30000, 30000) for _ in range(3)) if bend else ()
            supply, fault = rng.random() < 0.1, rng.random() < 0.1
            flags = SUPPLY_LOW * supply | SENSOR_FAULT * fault
            c_sample = c_board.sample(now_us, pressures, angles, flags)
            py_sample = py_board.sample(
                now_us * 1e-6, pressures, angles, supply_low=supply, sensor_fault=fault
            )
            assert c_sample == py_sample, step
            samples += bool(c_sample)
    assert answers > 500 and samples > 300  # both boards did stream and answer


def test_the_python_host_runs_a_session_with_the_c_board(core):
    """The host's link core on a port whose far end is the C board (same frames both ways)."""
    c_board = CBoard(core, default_capabilities())

    class Port:
        now_us = 0
        inbox = bytearray()

        def read(self):
            data, self.inbox = bytes(self.inbox), bytearray()
            return data

        def write(self, data):
            self.inbox += c_board.receive(data, self.now_us)

        def discard_input(self):
            self.inbox.clear()

        def close(self):
            pass

    port = Port()
    link = HostLink(LinkSettings(port='c board'), opener=lambda name, baud: port)
    (event,) = link.poll(0.0)
    assert isinstance(event, Connected) and event.capabilities == default_capabilities()
    received = []
    for k in range(1, 50):
        port.now_us = 10_000 * k
        if k == 10:
            link.send_openings((10000, 0, 0, 0, 10000, 10000), port.now_us * 1e-6)
        assert c_board.duties(port.now_us) == (
            (10000, 0, 0, 0, 10000, 10000) if k >= 10 else (0, 0, 0, 10000, 10000, 10000)
        )
        port.inbox += c_board.sample(port.now_us, (k, 2 * k, 3 * k), (k, -k, 0))
        received += [e for e in link.poll(port.now_us * 1e-6) if isinstance(e, SampleReceived)]
    assert len(received) == 49 and link.lost_samples == 0 and link.decoder.counts.bad == 0
    assert received[-1].sample.pressures_pa == (49, 98, 147)
    assert received[-1].sample.angles == (49, -49, 0)
    assert received[-1].sample.applied_sequence == 1


def test_the_arduino_sketch_compiles_against_the_core(tmp_path):
    """The sketch, as C++ against a stub of the Arduino core's declarations (syntax and types;
    the AVR build itself needs the Arduino toolchain, docs/hardware.md)."""
    compiler = shutil.which('c++') or shutil.which('g++') or shutil.which('clang++')
    if compiler is None:
        pytest.skip('no C++ compiler on this machine: the sketch is not compiled')
    sketch = CORE.parents[1] / 'exodigit_board.ino'
    stub = Path(__file__).resolve().parent / 'firmware_stub'
    result = subprocess.run(
        [compiler, '-std=c++11', '-Wall', '-Wextra', '-Werror', '-fsyntax-only', '-x', 'c++',
         '-include', 'Arduino.h', '-I', str(stub), str(sketch)],
        capture_output=True,
        text=True,
    )  # fmt: skip
    assert result.returncode == 0, result.stderr
