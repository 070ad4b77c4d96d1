"""``manigraph sim``: entry point (imports stay lazy so ``manigraph --help`` is fast)."""

from __future__ import annotations

import argparse

from manigraph_shared.bus_config import add_bus_arguments, bus_config_from_args
from manigraph_shared.cli import Command


def _configure(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "--backend", default="geometric", help="sim backend: geometric (default) or physics"
    )
    parser.add_argument("--publish-hz", type=float, default=10.0, help="scene rate (default 10)")
    parser.add_argument(
        "--goal-tolerance",
        type=float,
        default=None,
        help="metres from a goal that fill it (default: geometric 0.01, physics 0.02)",
    )
    parser.add_argument(
        "--realtime", action="store_true", help="physics: run in real time, not flat out"
    )
    parser.add_argument(
        "--video",
        default=None,
        help="physics: render each episode to this .gif/.mp4 ({episode}, {seed} allowed; "
        "needs Vulkan, see scripts/install-vulkan.sh)",
    )
    parser.add_argument(
        "--camera",
        action="store_true",
        help="physics: render the tripod camera (ArUco markers on every body) and publish "
        "its images, intrinsics and the episode layout (needs Vulkan)",
    )
    parser.add_argument(
        "--camera-hz", type=float, default=2.0, help="camera frames per second (default 2)"
    )
    parser.add_argument(
        "--camera-noise",
        type=float,
        default=0.0,
        help="Gaussian image noise, grey levels (default 0)",
    )
    parser.add_argument(
        "--camera-blur", type=int, default=0, help="horizontal motion blur, pixels (default 0)"
    )
    parser.add_argument(
        "--no-scenes",
        action="store_true",
        help="publish no ground-truth Scene: perception is the Scene source (with --camera)",
    )
    parser.add_argument(
        "--box-geometry",
        choices=["geometric", "physics"],
        default=None,
        help="geometric backend: lay box tasks out with this geometry (default geometric; "
        "physics: the physics world's roomier boxes, for comparing the two worlds)",
    )
    add_bus_arguments(parser)


def _run(args: argparse.Namespace) -> int:
    from manigraph_shared.errors import ConfigError
    from manigraph_shared.service import run_service
    from manigraph_sim import geometric, physics  # noqa: F401  (register the backends)
    from manigraph_sim.backend import create_backend
    from manigraph_sim.service import SimService

    if args.publish_hz <= 0 or args.publish_hz > 1000:
        raise ConfigError("publish-hz", "must be in (0, 1000]")
    options: dict[str, object] = {}
    if args.goal_tolerance is not None:
        if not 0 < args.goal_tolerance <= 0.1:
            raise ConfigError("goal-tolerance", "must be in (0, 0.1] metres")
        options["goal_tolerance"] = args.goal_tolerance
    if args.realtime:
        if args.backend != "physics":
            raise ConfigError("realtime", "only the physics backend simulates time")
        options["realtime"] = True
    if args.video:
        if args.backend != "physics":
            raise ConfigError("video", "only the physics backend renders")
        from manigraph_sim.physics.video import VideoConfig

        options["video"] = VideoConfig(args.video)
    if args.camera:
        if args.backend != "physics":
            raise ConfigError("camera", "only the physics backend renders")
        from manigraph_sim.physics.camera import CameraConfig

        options["camera"] = CameraConfig(
            hz=args.camera_hz, noise_sigma=args.camera_noise, blur_pixels=args.camera_blur
        )
    if args.no_scenes and not args.camera:
        raise ConfigError("no-scenes", "without --camera nothing would observe the world")
    if args.box_geometry is not None:
        if args.backend != "geometric":
            raise ConfigError("box-geometry", "the physics backend always has its own boxes")
        from manigraph_sim.physics.box_layout import PHYSICS_BOXES

        if args.box_geometry == "physics":
            options["boxes"] = PHYSICS_BOXES
    backend = create_backend(args.backend, **options)
    return run_service(
        lambda bus: SimService(
            bus,
            backend,
            args.publish_hz,
            scenes=not args.no_scenes,
            camera_hz=args.camera_hz if args.camera else 0.0,
        ),
        bus_config_from_args(args),
    )


command = Command(help="run the sim service (publishes Scene)", configure=_configure, run=_run)
