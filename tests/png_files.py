"""The size of a PNG file a command wrote, read from the file itself (no image library)."""

import struct

PNG_SIGNATURE = b'\x89PNG\r\n\x1a\n'


def png_size(path):
    """(width, height) in pixels from the IHDR chunk that must follow the PNG signature."""
    data = path.read_bytes()
    assert data[:8] == PNG_SIGNATURE
    assert data[12:16] == b'IHDR'
    return struct.unpack('>II', data[16:24])
