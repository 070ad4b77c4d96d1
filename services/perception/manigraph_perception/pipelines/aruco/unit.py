"""The ArUco pipeline as a registered unit (``manigraph perception --pipeline aruco``)."""

from __future__ import annotations

from manigraph_perception.pipeline import CameraSetup, OpenedPipeline, PipelineUnit
from manigraph_perception.pipelines.aruco.pipeline import Perception
from manigraph_perception.registry import ArucoOptions
from manigraph_shared.errors import ConfigError
from manigraph_shared.messages import MarkerDetections


def open_aruco(options: ArucoOptions, setup: CameraSetup) -> OpenedPipeline:
    """Markers from ``--markers`` (or the sim's), a fixed layout whose every object has one,
    and a ``cv2.VideoCapture`` source unless frames come from the bus."""
    from manigraph_perception.layout_file import load_layout
    from manigraph_perception.pipelines.aruco.sources import VideoSource
    from manigraph_shared.markers import load_marker_map, sim_marker_map

    if options.markers is None:
        raise ConfigError("markers", "--pipeline aruco needs a marker map (or 'sim')")
    markers = sim_marker_map() if options.markers == "sim" else load_marker_map(options.markers)
    perception = Perception(markers, setup.calibration, setup.camera_name, setup.world)
    layout = None
    if setup.layout_path is not None:
        layout = load_layout(setup.layout_path)
        perception.set_layout(layout)  # refuses an object with no marker, now
    source = None if setup.camera == "bus" else VideoSource(setup.camera)
    return OpenedPipeline(perception, source, layout)


UNIT = PipelineUnit(parts=Perception.parts, produces=(MarkerDetections,), open=open_aruco)
