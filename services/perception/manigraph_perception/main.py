"""``manigraph perception``: camera + ArUco markers -> Scene, or an RGB-D camera -> Scene
(``--pipeline rgbd``, no markers)."""

from __future__ import annotations

import argparse

from manigraph_shared.bus_config import add_bus_arguments, bus_config_from_args
from manigraph_shared.cli import Command


def _configure(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "--pipeline",
        choices=["aruco", "rgbd"],
        default="aruco",
        help="aruco: markers on the objects (default); rgbd: colour + depth, no markers "
        "(table plane, segmentation, colour; docs/perception.md)",
    )
    parser.add_argument(
        "--camera",
        required=True,
        help="'bus' (images from manigraph/camera/<name>/image, e.g. the sim's --camera; with "
        "--pipeline rgbd also .../depth), a V4L2 device (/dev/video0 or 0), a video file or a "
        "stream URL; with --pipeline rgbd: 'realsense' or an .mcap recording to replay",
    )
    parser.add_argument(
        "--markers",
        help="--pipeline aruco: marker map TOML (docs/perception.md), or 'sim' for the sim's "
        "printed markers",
    )
    parser.add_argument(
        "--calibration", required=True, help="OpenCV FileStorage YAML with base_T_camera"
    )
    parser.add_argument(
        "--layout", default=None, help="layout TOML (default: the TaskLayout the sim publishes)"
    )
    parser.add_argument(
        "--identity",
        choices=["appearance", "prior"],
        default="appearance",
        help="--pipeline rgbd: how an object is first told apart. appearance (default): the "
        "layout's starting positions are not used; each object is found by its colour and "
        "size. prior: matched by distance from its starting position (the old behaviour)",
    )
    parser.add_argument("--camera-name", default="front", help="camera name on the bus")
    parser.add_argument(
        "--stale-after", type=float, default=2.0, help="seconds without a frame (default 2)"
    )
    add_bus_arguments(parser)


def _run(args: argparse.Namespace) -> int:
    from manigraph_perception.calibration_file import load_calibration
    from manigraph_perception.layout_file import load_layout
    from manigraph_perception.pipeline import Perception
    from manigraph_perception.service import PerceptionService
    from manigraph_perception.sources import VideoSource
    from manigraph_perception.world_belief import WorldConfig
    from manigraph_shared.bus import Bus
    from manigraph_shared.errors import ConfigError
    from manigraph_shared.markers import load_marker_map, sim_marker_map
    from manigraph_shared.service import run_service

    if not 0 < args.stale_after <= 60:
        raise ConfigError("stale-after", "must be in (0, 60] seconds")
    if args.pipeline == "rgbd":
        from manigraph_perception.rgbd.main import run_rgbd

        return run_rgbd(args)
    if args.markers is None:
        raise ConfigError("markers", "--pipeline aruco needs a marker map (or 'sim')")
    markers = sim_marker_map() if args.markers == "sim" else load_marker_map(args.markers)
    calibration = load_calibration(args.calibration)
    perception = Perception(
        markers, calibration, args.camera_name, WorldConfig(stale_after=args.stale_after)
    )
    layout = None
    if args.layout is not None:
        layout = load_layout(args.layout)
        perception.set_layout(layout)  # refuses an object with no marker, now
    source = None if args.camera == "bus" else VideoSource(args.camera)
    services: list[PerceptionService] = []

    def make(bus: Bus) -> PerceptionService:
        service = PerceptionService(bus, perception, source, layout)
        services.append(service)
        return service

    code = run_service(make, bus_config_from_args(args))
    return 1 if services and services[0].failed else code


command = Command(
    help="run camera perception: ArUco markers -> Scene", configure=_configure, run=_run
)
