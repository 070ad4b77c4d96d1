"""The RGB-D pipeline as a registered unit (``manigraph perception --pipeline rgbd``)."""

from __future__ import annotations

from manigraph_perception.pipeline import CameraSetup, OpenedPipeline, PipelineUnit
from manigraph_perception.pipelines.rgbd.pipeline import RgbdPerception
from manigraph_perception.registry import RgbdOptions


def open_rgbd(options: RgbdOptions, setup: CameraSetup) -> OpenedPipeline:
    """Objects found by ``--identity``; a fixed layout (a task file: with appearance identity
    its objects need no position); a RealSense or a recording unless frames come from the bus."""
    from manigraph_perception.layout_file import load_layout
    from manigraph_perception.pipelines.rgbd.identity import IdentityMode
    from manigraph_perception.pipelines.rgbd.sources import open_rgbd_source

    identity = IdentityMode(options.identity)
    calibration = setup.calibration
    perception = RgbdPerception(calibration, setup.camera_name, setup.world, identity=identity)
    layout = None
    if setup.layout_path is not None:
        layout = load_layout(setup.layout_path, positions=identity is IdentityMode.PRIOR)
    source = None
    if setup.camera != "bus":
        size = (calibration.width, calibration.height)
        source = open_rgbd_source(setup.camera, setup.camera_name, size)
    return OpenedPipeline(perception, source, layout)


UNIT = PipelineUnit(parts=RgbdPerception.parts, produces=(), open=open_rgbd)
