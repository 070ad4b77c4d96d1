"""Camera images, intrinsics and the markers detected in them (sim camera or a real one).

Images travel encoded (JPEG or PNG bytes, base64 in the JSON), so a 640 x 480 frame is
~50-150 kB on the wire, well under the payload limit. In MCAP logs the conversion in
``manigraph_tools.foxglove_camera`` shows them in Foxglove's Image panel
(``foxglove.CompressedImage``, ``foxglove.CameraCalibration``, ``foxglove.ImageAnnotations``).
"""

from __future__ import annotations

from enum import StrEnum
from typing import Annotated, ClassVar

import msgspec
from msgspec import Meta

from manigraph_shared.messages.base import Delivery, Identifier, Message, Stamp, Struct

#: Largest encoded image accepted (the message must stay under ``MAX_PAYLOAD_BYTES`` after
#: base64's 4/3).
MAX_IMAGE_BYTES = 700_000

Pixels = Annotated[float, Meta(ge=-1e5, le=1e5, description="pixels")]


class ImageFormat(StrEnum):
    JPEG = "jpeg"
    PNG = "png"


class CompressedImage(Message, frozen=True, kw_only=True):
    """One encoded camera frame."""

    key: ClassVar[str] = "manigraph/camera/{camera}/image"
    delivery: ClassVar[Delivery] = Delivery.LATEST
    publisher: ClassVar[str] = "sim (--camera) or a camera driver"

    camera: Annotated[Identifier, Meta(description="camera name (also its optical frame id)")]
    stamp: Annotated[Stamp, Meta(description="when the frame was exposed")]
    sequence: Annotated[int, Meta(ge=0, description="increases by one per frame")]
    format: ImageFormat
    data: Annotated[
        bytes, Meta(max_length=MAX_IMAGE_BYTES, description="encoded image, base64 in JSON")
    ]


class DepthEncoding(StrEnum):
    #: A 16-bit single-channel PNG of millimetres along the optical axis (z, not the ray's
    #: length); 0 is "no depth here" (a hole, an edge the sensor dropped, out of range). The
    #: encoding of a RealSense's ``z16`` stream at its default 1 mm unit and of ROS's
    #: ``16UC1`` depth images.
    PNG16_MM = "png16-mm"


class DepthImage(Message, frozen=True, kw_only=True):
    """One depth frame, registered to the colour image of the same camera and ``sequence``
    (same size, same intrinsics: the ``CameraInfo`` of that camera)."""

    key: ClassVar[str] = "manigraph/camera/{camera}/depth"
    delivery: ClassVar[Delivery] = Delivery.LATEST
    publisher: ClassVar[str] = "sim (--camera --camera-depth) or an RGB-D camera driver"

    camera: Annotated[Identifier, Meta(description="camera name (also its optical frame id)")]
    stamp: Annotated[Stamp, Meta(description="when the frame was exposed")]
    sequence: Annotated[
        int, Meta(ge=0, description="the sequence of the colour image it belongs to")
    ]
    encoding: Annotated[
        DepthEncoding, Meta(description="png16-mm: 16-bit PNG of millimetres, 0 no depth")
    ] = DepthEncoding.PNG16_MM
    data: Annotated[
        bytes, Meta(max_length=MAX_IMAGE_BYTES, description="encoded depth, base64 in JSON")
    ]


class CameraInfo(Message, frozen=True, kw_only=True):
    """A camera's intrinsics: pinhole matrix and distortion, OpenCV conventions."""

    key: ClassVar[str] = "manigraph/camera/{camera}/info"
    delivery: ClassVar[Delivery] = Delivery.LATEST
    publisher: ClassVar[str] = "sim (--camera) or a camera driver"

    camera: Identifier
    stamp: Stamp
    width: Annotated[int, Meta(ge=1, le=8192, description="pixels")]
    height: Annotated[int, Meta(ge=1, le=8192, description="pixels")]
    camera_matrix: Annotated[
        list[Pixels],
        Meta(
            min_length=9, max_length=9, description="K, row-major 3 x 3 (fx 0 cx; 0 fy cy; 0 0 1)"
        ),
    ]
    distortion: Annotated[
        list[float],
        Meta(max_length=14, description="OpenCV distortion coefficients (k1 k2 p1 p2 k3 ...)"),
    ] = msgspec.field(default_factory=lambda: [0.0] * 5)

    def _check(self) -> None:
        k = self.camera_matrix
        if k[0] <= 0 or k[4] <= 0 or k[8] != 1.0 or k[1] != 0 or k[3] != 0 or k[6:8] != [0, 0]:
            raise ValueError("camera_matrix: must be [fx 0 cx; 0 fy cy; 0 0 1], fx, fy > 0")


class DetectedMarker(Struct, frozen=True, kw_only=True):
    """One square marker found in an image."""

    id: Annotated[int, Meta(ge=0, le=4095, description="marker id in the dictionary")]
    corners: Annotated[
        list[Pixels],
        Meta(
            min_length=8, max_length=8, description="x, y of the 4 corners, clockwise from top-left"
        ),
    ]
    object_id: Annotated[
        str, Meta(max_length=64, description="object it belongs to ('' unknown)")
    ] = ""


class MarkerDetections(Message, frozen=True, kw_only=True):
    """The markers perception found in one camera frame (for viewers and logs)."""

    key: ClassVar[str] = "manigraph/camera/{camera}/markers"
    delivery: ClassVar[Delivery] = Delivery.LATEST
    publisher: ClassVar[str] = "perception"

    camera: Identifier
    stamp: Annotated[Stamp, Meta(description="stamp of the image they were found in")]
    markers: Annotated[list[DetectedMarker], Meta(max_length=1024)]
