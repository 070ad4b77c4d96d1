"""What the perception service consumes and produces (see ``manigraph_shared.manifest``)."""

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

MANIFEST = Manifest(
    service="perception",
    summary="camera + ArUco markers, or RGB-D",
    consumes=(
        port(CompressedImage),
        port(DepthImage),
        port(CameraInfo),
        port(TaskLayout),
        port(Action),
        port(JointState),
    ),
    produces=(port(Scene), port(MarkerDetections), port(ServiceStatus)),
)
