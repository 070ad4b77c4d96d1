"""Camera frames for a LeRobot dataset: the frame each decision was made with, and its size.

manigraph logs frames encoded (``CompressedImage``: JPEG or PNG). LeRobot's ``image`` columns
hold encoded images too (``{"bytes", "path"}`` as the ``datasets`` library embeds them), so
frames are copied byte for byte and never re-encoded. The size a column declares is read from
the image's header, which needs no image library.
"""

from __future__ import annotations

import struct
from dataclasses import dataclass, field

from manigraph_shared.errors import LogError
from manigraph_shared.messages import CompressedImage

_PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"
#: JPEG start-of-frame markers (baseline, progressive, ...): every SOFn but DHT, JPG and DAC.
_JPEG_SOF = frozenset(range(0xC0, 0xD0)) - {0xC4, 0xC8, 0xCC}


def image_size(data: bytes) -> tuple[int, int]:
    """``(height, width)`` of an encoded PNG or JPEG image."""
    if data.startswith(_PNG_SIGNATURE) and len(data) >= 24:
        width, height = struct.unpack(">II", data[16:24])
        return height, width
    if data.startswith(b"\xff\xd8"):
        at = 2
        while at + 9 <= len(data):
            if data[at] != 0xFF:
                break
            marker = data[at + 1]
            if marker == 0xFF:  # fill byte
                at += 1
                continue
            (length,) = struct.unpack(">H", data[at + 2 : at + 4])
            if marker in _JPEG_SOF:
                height, width = struct.unpack(">HH", data[at + 5 : at + 9])
                return height, width
            at += 2 + length
    raise LogError("camera: a frame is neither a PNG nor a JPEG with a readable size")


@dataclass
class LatestFrames:
    """The last frame seen of each camera while reading a log in file order."""

    latest: dict[str, CompressedImage] = field(default_factory=dict)
    sizes: dict[str, tuple[int, int]] = field(default_factory=dict)

    def see(self, image: CompressedImage) -> None:
        size = image_size(image.data)
        known = self.sizes.setdefault(image.camera, size)
        if known != size:
            raise LogError(
                f"camera: '{image.camera}' changed size from {known} to {size} within the log"
            )
        self.latest[image.camera] = image

    def snapshot(self) -> dict[str, bytes]:
        """Each camera's latest encoded frame now."""
        return {camera: image.data for camera, image in self.latest.items()}
