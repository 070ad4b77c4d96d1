"""What an encoded image costs, known before it is decoded; OpenCV's errors, named.

A PNG or JPEG says its size in its first bytes (PNG's IHDR chunk, JPEG's start-of-frame
segment), and decoding allocates that size whatever the file weighs: 630 kB of deflated
zeros declare 18000 x 18000 16-bit pixels (648 MB decoded, 2.6 GB as metres in float64).
So every frame from the bus is checked against the size the camera was calibrated for from
its header alone, and refused by name without being decoded (HOUSE_STYLE point 12: the
cheapest check first).

OpenCV raises ``cv2.error`` with its source file, line and assertion text (``OpenCV(5.0.0)
/io/opencv/modules/imgproc/src/color.cpp:199: error: (-215:Assertion failed) !_src.empty()
in function 'cvtColor'``): :func:`opencv_reason` keeps what a user can act on, the step that
failed and the kind of error, for the service's status and log.
"""

from __future__ import annotations

import re
import struct
from dataclasses import dataclass
from typing import NamedTuple

import cv2

PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"
#: Channels per PNG colour type (grey, RGB, palette, grey + alpha, RGBA).
_PNG_CHANNELS = {0: 1, 2: 3, 3: 1, 4: 2, 6: 4}
#: JPEG start-of-frame markers (baseline, extended, progressive, lossless, ...): not DHT
#: (C4), JPG (C8) or DAC (CC), which share the range.
_JPEG_SOF = {0xC0, 0xC1, 0xC2, 0xC3, 0xC5, 0xC6, 0xC7, 0xC9, 0xCA, 0xCB, 0xCD, 0xCE, 0xCF}
#: JPEG markers without a length: TEM, RST0-7, SOI.
_JPEG_BARE = {0x01, *range(0xD0, 0xD9)}


class UnreadableHeader(ValueError):
    """An image whose header does not say its size (not a PNG or a JPEG, truncated)."""


@dataclass(frozen=True)
class ImageHeader:
    format: str  # "png" or "jpeg"
    width: int
    height: int
    bit_depth: int  # bits per sample
    channels: int

    def describe(self) -> str:
        return f"{self.width} x {self.height}"


def read_header(data: bytes) -> ImageHeader:
    """The size and sample format ``data`` declares, read without decoding any pixel;
    ``UnreadableHeader`` naming why not."""
    if data.startswith(PNG_SIGNATURE):
        return _png_header(data)
    if data.startswith(b"\xff\xd8"):
        return _jpeg_header(data)
    raise UnreadableHeader(f"neither PNG nor JPEG (starts {data[:4].hex(' ') or 'empty'})")


def _png_header(data: bytes) -> ImageHeader:
    # Signature, then the IHDR chunk first: length 13, type, width, height, bit depth, colour
    # type (PNG spec 11.2.2).
    if len(data) < 26:
        raise UnreadableHeader("PNG truncated before its IHDR chunk")
    length, kind, width, height, bit_depth, colour = struct.unpack(">I4sIIBB", data[8:26])
    if kind != b"IHDR" or length != 13:
        raise UnreadableHeader("PNG does not start with its IHDR chunk")
    if colour not in _PNG_CHANNELS:
        raise UnreadableHeader(f"PNG colour type {colour} does not exist")
    return ImageHeader("png", width, height, bit_depth, _PNG_CHANNELS[colour])


def _jpeg_header(data: bytes) -> ImageHeader:
    # Segments after SOI: 0xFF, marker, then (most) a 2-byte length that counts itself. The
    # frame header (SOFn) comes before the first scan (SOS); fill bytes 0xFF may pad.
    at = 2
    while at + 4 <= len(data):
        if data[at] != 0xFF:
            raise UnreadableHeader(f"JPEG segment without a marker at byte {at}")
        marker = data[at + 1]
        if marker == 0xFF:
            at += 1
            continue
        if marker in _JPEG_BARE:
            at += 2
            continue
        (length,) = struct.unpack(">H", data[at + 2 : at + 4])
        if marker in _JPEG_SOF:
            if length < 8 or at + 10 > len(data):
                raise UnreadableHeader("JPEG frame header truncated")
            precision, height, width, components = struct.unpack(">BHHB", data[at + 4 : at + 10])
            if height == 0:  # the height comes later, in a DNL segment: refused, not guessed
                raise UnreadableHeader("JPEG frame header defers its height (DNL)")
            return ImageHeader("jpeg", width, height, precision, components)
        if marker in (0xDA, 0xD9) or length < 2:
            break
        at += 2 + length
    raise UnreadableHeader("JPEG without a frame header before its image data")


class ImageProblem(NamedTuple):
    """Why an image cannot be a frame: ``kind`` (``wrong_size``: a size other than the
    calibrated one; ``unreadable``: no size or format to check) and the reason, named."""

    kind: str
    reason: str


def size_problem(what: str, data: bytes, width: int, height: int) -> ImageProblem | None:
    """Why ``data`` (``what``: "depth", "colour image") cannot be a frame of a ``width`` x
    ``height`` camera, from its header alone (None: it can be)."""
    try:
        header = read_header(data)
    except UnreadableHeader as exc:
        return ImageProblem("unreadable", f"{what} does not decode: {exc}")
    if (header.width, header.height) != (width, height):
        return ImageProblem(
            "wrong_size",
            f"{what} {header.describe()}, calibrated for {width} x {height} "
            f"(refused from its {header.format.upper()} header, not decoded)",
        )
    return None


def depth_problem(data: bytes, width: int, height: int) -> ImageProblem | None:
    """``size_problem`` for a ``png16-mm`` depth image, which must also be 16-bit grey."""
    problem = size_problem("depth", data, width, height)
    if problem is not None:
        return problem
    header = read_header(data)
    if header.format != "png" or header.bit_depth != 16 or header.channels != 1:
        return ImageProblem(
            "unreadable",
            f"depth is a {header.bit_depth}-bit {header.format.upper()} of {header.channels} "
            "channel(s), not the 16-bit grey PNG of millimetres (png16-mm)",
        )
    return None


#: OpenCV's error codes (``cv::Error::Code``) as words; others are given by number.
_OPENCV_CODES = {
    -2: "unknown error",
    -3: "internal error",
    -4: "out of memory",
    -5: "bad argument",
    -10: "bad image size",
    -201: "bad size",
    -205: "unmatched formats",
    -210: "unsupported format",
    -211: "out of range",
    -212: "parse error",
    -213: "not implemented",
    -215: "assertion failed",
}


def _opencv_code(code: object) -> str:
    if not isinstance(code, int):
        return "error"
    if code in _OPENCV_CODES:
        return _OPENCV_CODES[code]
    # cv::Error's own names (BadNumChannels -> "bad num channels"), else the number.
    names = [n for n in dir(cv2.Error) if n[:1].isupper() and getattr(cv2.Error, n) == code]
    camel = [n for n in names if not n.isupper()]
    if not camel:
        return f"error {code}"
    words = re.findall(r"[A-Z][a-z]*", camel[0].removeprefix("Sts"))
    return " ".join(words).lower() or f"error {code}"


def _opencv_function(signature: str) -> str:
    """``cvtColor`` of ``cvtColor``; ``CvtHelper`` of a C++ signature with templates."""
    name = signature.split("(")[0]
    while (shorter := re.sub(r"<[^<>]*>", "", name)) != name:
        name = shorter
    name = name.rsplit("::", 1)[-1].strip()
    return name if name.isidentifier() and len(name) <= 40 else ""


def opencv_reason(error: cv2.error, doing: str) -> str:
    """A short named reason for ``error``, raised while ``doing`` something: the OpenCV
    function and the kind of error, without its source path or assertion text
    (``opencv failed decoding it: imdecode_ (assertion failed)``)."""
    kind = _opencv_code(getattr(error, "code", None))
    function = _opencv_function(str(getattr(error, "func", "") or ""))
    return f"opencv failed {doing}: {function + ' ' if function else ''}({kind})"
