"""Images that weigh little and decode to a lot: what a forger sends a camera's subscriber.

``zero_png(18000, 18000)`` is the 630 kB depth image of issue 48: a real, valid 16-bit grey
PNG (libpng and OpenCV decode it) of 648 MB of zeros. It is built without deflating 648 MB:
one block of rows is deflated with a full flush (byte-aligned, no history), which may be
repeated as often as wanted in one zlib stream, and the Adler-32 of all-zero data has a
closed form (``a`` stays 1, ``b`` counts the bytes).
"""

from __future__ import annotations

import struct
import zlib
from functools import lru_cache

PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"
_ADLER_MOD = 65521


def _chunk(kind: bytes, body: bytes) -> bytes:
    return struct.pack(">I", len(body)) + kind + body + struct.pack(">I", zlib.crc32(kind + body))


@lru_cache(maxsize=8)
def zero_png(width: int, height: int, bit_depth: int = 16, rows_per_block: int = 1000) -> bytes:
    """A grey PNG of ``width`` x ``height`` zeros (``bit_depth`` 8 or 16), deflated at
    level 9 (18000 x 18000 x 16 bits: ~630 kB)."""
    row = (width * bit_depth + 7) // 8 + 1  # the filter byte (0: none) and the samples
    block = min(rows_per_block, height)
    whole, rest = divmod(height, block)

    def deflated(rows: int) -> bytes:
        raw = zlib.compressobj(9, zlib.DEFLATED, -15)
        return raw.compress(bytes(row * rows)) + raw.flush(zlib.Z_FULL_FLUSH)

    final = zlib.compressobj(9, zlib.DEFLATED, -15).flush()  # an empty last block
    total = row * height
    adler = ((total % _ADLER_MOD) << 16) | 1
    stream = (
        b"\x78\xda"
        + deflated(block) * whole
        + (deflated(rest) if rest else b"")
        + final
        + struct.pack(">I", adler)
    )
    header = struct.pack(">IIBBBBB", width, height, bit_depth, 0, 0, 0, 0)
    return PNG_SIGNATURE + _chunk(b"IHDR", header) + _chunk(b"IDAT", stream) + _chunk(b"IEND", b"")
