"""``manigraph perception --pipeline rgbd``: the RGB-D pipeline as a service."""

from __future__ import annotations

import argparse


def run_rgbd(args: argparse.Namespace) -> int:
    from manigraph_perception.calibration_file import load_calibration
    from manigraph_perception.layout_file import load_layout
    from manigraph_perception.rgbd.identity import IdentityMode
    from manigraph_perception.rgbd.pipeline import RgbdPerception
    from manigraph_perception.rgbd.service import RgbdPerceptionService
    from manigraph_perception.rgbd.sources import open_rgbd_source
    from manigraph_perception.world_belief import WorldConfig
    from manigraph_shared.bus import Bus
    from manigraph_shared.bus_config import bus_config_from_args
    from manigraph_shared.service import run_service

    calibration = load_calibration(args.calibration)
    identity = IdentityMode(args.identity)
    perception = RgbdPerception(
        calibration,
        args.camera_name,
        WorldConfig(stale_after=args.stale_after),
        identity=identity,
    )
    layout = None
    if args.layout is not None:
        # A task file serves: with appearance identity its objects need no position.
        layout = load_layout(args.layout, positions=identity is IdentityMode.PRIOR)
    size = (calibration.width, calibration.height)
    source = None
    if args.camera != "bus":
        source = open_rgbd_source(args.camera, args.camera_name, size)
    services: list[RgbdPerceptionService] = []

    def make(bus: Bus) -> RgbdPerceptionService:
        service = RgbdPerceptionService(bus, perception, source, layout)
        services.append(service)
        return service

    code = run_service(make, bus_config_from_args(args))
    return 1 if services and services[0].failed else code
