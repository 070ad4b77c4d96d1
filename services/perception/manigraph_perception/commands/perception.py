"""``manigraph perception``: a camera -> Scene, through a registered pipeline (``--pipeline``:
ArUco markers by default, or RGB-D without markers; ``manigraph_perception.registry``)."""

from __future__ import annotations

import argparse

from manigraph_perception.registry import PIPELINES
from manigraph_shared.bus_config import add_bus_arguments, bus_config_from_args
from manigraph_shared.cli import Command


def _configure(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "--pipeline",
        default="aruco",
        help=f"how objects are seen (default: aruco); {PIPELINES.describe()}",
    )
    parser.add_argument(
        "--camera",
        required=True,
        help="'bus' (images from manigraph/camera/<name>/image, e.g. the sim's --camera; with "
        "--pipeline rgbd also .../depth), a V4L2 device (/dev/video0 or 0), a video file or a "
        "stream URL; with --pipeline rgbd: 'realsense' or an .mcap recording to replay",
    )
    parser.add_argument(
        "--calibration", required=True, help="OpenCV FileStorage YAML with base_T_camera"
    )
    parser.add_argument(
        "--layout", default=None, help="layout TOML (default: the TaskLayout the sim publishes)"
    )
    parser.add_argument("--camera-name", default="front", help="camera name on the bus")
    parser.add_argument(
        "--stale-after", type=float, default=2.0, help="seconds without a frame (default 2)"
    )
    PIPELINES.add_arguments(parser.add_argument_group("pipeline options"))
    add_bus_arguments(parser)


def _run(args: argparse.Namespace) -> int:
    from manigraph_perception.calibration_file import load_calibration
    from manigraph_perception.pipeline import CameraSetup
    from manigraph_perception.registry import open_pipeline
    from manigraph_perception.service import PerceptionService
    from manigraph_perception.world_belief import WorldConfig
    from manigraph_shared.bus import Bus
    from manigraph_shared.errors import ConfigError
    from manigraph_shared.service import run_service

    if not 0 < args.stale_after <= 60:
        raise ConfigError("stale-after", "must be in (0, 60] seconds")
    PIPELINES.check(args.pipeline)
    setup = CameraSetup(
        camera=args.camera,
        camera_name=args.camera_name,
        calibration=load_calibration(args.calibration),
        world=WorldConfig(stale_after=args.stale_after),
        layout_path=args.layout,
    )
    opened = open_pipeline(args.pipeline, setup, **PIPELINES.given_options(args))
    services: list[PerceptionService] = []

    def make(bus: Bus) -> PerceptionService:
        service = PerceptionService(bus, opened.pipeline, opened.source, opened.layout)
        services.append(service)
        return service

    code = run_service(make, bus_config_from_args(args))
    return 1 if services and services[0].failed else code


command = Command(
    help="run camera perception: ArUco markers or RGB-D -> Scene", configure=_configure, run=_run
)
