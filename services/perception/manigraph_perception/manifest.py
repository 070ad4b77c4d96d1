"""What the perception service consumes and produces (see ``manigraph_shared.manifest``)."""

from manigraph_shared.manifest import Manifest, port
from manigraph_shared.messages import Scene, ServiceStatus

MANIFEST = Manifest(
    service="perception",
    summary="camera + ArUco markers",
    produces=(port(Scene), port(ServiceStatus)),
)
