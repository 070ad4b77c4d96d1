"""What the perception service consumes and produces (see ``manigraph_shared.manifest``).

One variant per registered pipeline (``--pipeline``, ``registry.py``), by what it brings:
``markers`` (ArUco: a colour image is enough, and it publishes the markers it found) or
``depth`` (RGB-D: it needs the depth image of each colour image).
"""

from manigraph_shared.manifest import Manifest, port
from manigraph_shared.messages import (
    Action,
    CameraInfo,
    CompressedImage,
    DepthImage,
    JointState,
    MarkerDetections,
    Scene,
    ServiceStatus,
    TaskLayout,
)

MARKERS = "markers"
DEPTH = "depth"

MANIFEST = Manifest(
    service="perception",
    summary="camera + ArUco markers, or RGB-D",
    consumes=(
        port(CompressedImage),
        port(DepthImage, DEPTH),
        port(CameraInfo),
        port(TaskLayout),
        port(Action),
        port(JointState),
    ),
    produces=(port(Scene), port(MarkerDetections, MARKERS), port(ServiceStatus)),
    variant_option="pipeline",
    variants={"aruco": frozenset({MARKERS}), "rgbd": frozenset({DEPTH})},
)
