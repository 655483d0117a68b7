"""The host's serial port (pyserial): opened non-blocking, read what is there, write frames.

Any pyserial port name works (``/dev/ttyACM0``, ``COM3``, a pseudo-terminal, ``loop://``).
Every failure of the port (absent, unplugged, refused) is a :class:`PortError` with one line.
"""

from __future__ import annotations

import contextlib

import serial

READ_CHUNK = 4096
"""Most bytes taken from the port in one read."""
WRITE_TIMEOUT = 0.1
"""Longest a write may block on a full output buffer before the port counts as failed, s."""


class PortError(OSError):
    """The port cannot be opened, read or written (absent, unplugged, busy)."""


class SerialPort:
    """One open serial port.

    Parameters
    ----------
    name : str
        pyserial port name or URL.
    baud_rate : int
        Bits per second, 8N1 (USB CDC boards and pseudo-terminals ignore it).

    Raises
    ------
    PortError
        If the port does not open.
    """

    def __init__(self, name: str, baud_rate: int) -> None:
        self.name = name
        try:
            self._serial = serial.serial_for_url(
                name, baudrate=baud_rate, timeout=0, write_timeout=WRITE_TIMEOUT
            )
        except (serial.SerialException, OSError, ValueError) as error:
            raise PortError(f'cannot open {name}: {_reason(error)}') from None

    def fileno(self) -> int | None:
        """The descriptor to wait on with select (None for ports that have none)."""
        try:
            return self._serial.fileno()
        except (AttributeError, serial.SerialException):
            return None

    def read(self) -> bytes:
        """The bytes waiting (b'' if none); :class:`PortError` if the port failed."""
        try:
            return self._serial.read(max(1, min(self._serial.in_waiting, READ_CHUNK)))
        except (serial.SerialException, OSError) as error:
            raise PortError(f'{self.name}: {_reason(error)}') from None

    def write(self, data: bytes) -> None:
        """Write ``data`` whole; :class:`PortError` if the port failed or stayed full."""
        try:
            self._serial.write(data)
        except (serial.SerialException, OSError) as error:
            raise PortError(f'{self.name}: {_reason(error)}') from None

    def discard_input(self) -> None:
        """Drop what the port has received and not yet been read."""
        try:
            self._serial.reset_input_buffer()
        except (serial.SerialException, OSError) as error:
            raise PortError(f'{self.name}: {_reason(error)}') from None

    def close(self) -> None:
        """Close the port (never raises)."""
        with contextlib.suppress(serial.SerialException, OSError):
            self._serial.close()


def _reason(error: Exception) -> str:
    """An exception's text on one line."""
    return ' '.join(str(error).split()) or type(error).__name__
