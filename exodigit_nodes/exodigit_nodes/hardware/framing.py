"""Frames on the serial link (docs/spec/hardware.md §2): COBS, CRC-16, a zero delimiter.

A frame on the wire is ``COBS(payload ‖ crc) ‖ 0x00``: the payload (a message type byte and
its body, :mod:`.messages`), its CRC-16/CCITT-FALSE (polynomial 0x1021, initial value 0xFFFF,
no reflection, no final XOR; check value 0x29B1 for ``b'123456789'``) appended little-endian,
the whole stuffed by Consistent Overhead Byte Stuffing so that it holds no zero byte, then one
zero byte that ends it. A receiver that joins mid-stream, or loses bytes, is back in step at
the next zero.
"""

from __future__ import annotations

import binascii
from dataclasses import dataclass

from cobs import cobs

CRC_INITIAL = 0xFFFF
"""The CRC register's initial value (CRC-16/CCITT-FALSE)."""
CRC_BYTES = 2
DELIMITER = b'\x00'
MAX_PAYLOAD = 64
"""Largest payload (type byte and body), bytes."""
MAX_FRAME = MAX_PAYLOAD + CRC_BYTES + 1
"""Largest stuffed frame without its delimiter, bytes (COBS adds one byte per 254)."""


def crc16(data: bytes) -> int:
    """CRC-16/CCITT-FALSE of ``data`` (stdlib ``binascii.crc_hqx`` from 0xFFFF)."""
    return binascii.crc_hqx(data, CRC_INITIAL)


def encode_frame(payload: bytes) -> bytes:
    """The wire bytes of one payload: stuffed payload and CRC, then the delimiter.

    Raises
    ------
    ValueError
        For an empty payload or one longer than :data:`MAX_PAYLOAD`.
    """
    if not 0 < len(payload) <= MAX_PAYLOAD:
        raise ValueError(f'payload of {len(payload)} bytes: must be 1 to {MAX_PAYLOAD} bytes')
    checked = payload + crc16(payload).to_bytes(CRC_BYTES, 'little')
    return cobs.encode(checked) + DELIMITER


@dataclass
class FrameCounts:
    """What a :class:`FrameDecoder` has seen, frames.

    Attributes
    ----------
    good : int
        Frames whose CRC matched.
    bad_checksum : int
        Frames that unstuffed but whose CRC did not match.
    bad_stuffing : int
        Frames that are no valid COBS, or too short to hold a type and a CRC.
    overlong : int
        Runs of bytes longer than :data:`MAX_FRAME` without a delimiter (dropped to the next).
    """

    good: int = 0
    bad_checksum: int = 0
    bad_stuffing: int = 0
    overlong: int = 0

    @property
    def bad(self) -> int:
        """Every frame thrown away."""
        return self.bad_checksum + self.bad_stuffing + self.overlong


class FrameDecoder:
    """Turns a byte stream into checked payloads; never raises for what the stream holds.

    Bytes accumulate until a zero; the run is then unstuffed and its CRC checked. A run longer
    than :data:`MAX_FRAME` is dropped up to the next zero (counted once). Empty runs (two zeros
    in a row, as a sender may put first to flush a receiver) are ignored.
    """

    def __init__(self) -> None:
        self.counts = FrameCounts()
        self._buffer = bytearray()
        self._overlong = False

    def feed(self, data: bytes) -> list[bytes]:
        """The payloads of every frame that ``data`` completes (CRC stripped), in order."""
        payloads = []
        start = 0
        while True:
            end = data.find(DELIMITER, start)
            if end < 0:
                self._take(data[start:])
                return payloads
            self._take(data[start:end])
            run, overlong = bytes(self._buffer), self._overlong
            self._buffer.clear()
            self._overlong = False
            start = end + 1
            if run and not overlong:
                payload = self._payload(run)
                if payload is not None:
                    payloads.append(payload)

    def discard(self) -> None:
        """Drop a partly received frame (a new port); the counts stay."""
        self._buffer.clear()
        self._overlong = False

    def _take(self, part: bytes) -> None:
        """Append ``part`` to the current run unless it grows past :data:`MAX_FRAME`."""
        if self._overlong:
            return
        if len(self._buffer) + len(part) > MAX_FRAME:
            self._overlong = True
            self._buffer.clear()
            self.counts.overlong += 1
            return
        self._buffer += part

    def _payload(self, run: bytes) -> bytes | None:
        """The checked payload of one run, or None (counted)."""
        try:
            checked = cobs.decode(run)
        except cobs.DecodeError:
            checked = b''
        if len(checked) <= CRC_BYTES:
            self.counts.bad_stuffing += 1
            return None
        payload, crc = checked[:-CRC_BYTES], checked[-CRC_BYTES:]
        if crc16(payload) != int.from_bytes(crc, 'little'):
            self.counts.bad_checksum += 1
            return None
        self.counts.good += 1
        return payload
