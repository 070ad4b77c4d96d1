"""The sim backends, registered by name with their options.

This module imports neither a backend nor SAPIEN: ``manigraph sim --help`` (and ``manigraph
up``, which forwards backend options) list every backend's flags from the options here, and a
backend's module is imported only when it is created.

Register a new backend with its options dataclass::

    @dataclass(frozen=True)
    class MyOptions(Options):
        speed: float = option(1.0, help="...", within=Interval(0, 10, low_open=True))

    BACKENDS.add_lazy("mine", "my_package.backend:MyBackend", options=MyOptions)

``MyBackend.from_options(options)`` then builds it
(:class:`~manigraph_sim.backend_base.SimBackend`).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any, Literal

from manigraph_shared.options import Interval, Options, option
from manigraph_shared.registry import Registry

if TYPE_CHECKING:
    from manigraph_sim.backend_base import SimBackend

__all__ = ["BACKENDS", "GeometricOptions", "PhysicsOptions", "create_backend"]

#: Metres from a goal's centre within which an object fills it.
GOAL_TOLERANCE = Interval(0, 0.1, low_open=True)
#: Rates streamed in real time: at most one sample per physics step (5 ms).
STREAM_RATE = Interval(0, 200, low_open=True)


@dataclass(frozen=True)
class GeometricOptions(Options):
    goal_tolerance: float = option(
        0.01, help="how close to a goal fills it", within=GOAL_TOLERANCE, unit="metres"
    )
    box_geometry: Literal["geometric", "physics"] | None = option(
        None,
        help="lay box tasks out with this geometry (unset: geometric; physics: the physics "
        "world's roomier boxes, for comparing the two worlds)",
    )
    workspace: str | None = option(
        None,
        help="box the gripper may reach, xmin,xmax,ymin,ymax,zmin,zmax in metres (unset: the "
        "skills' default); commands outside it are refused",
    )


@dataclass(frozen=True)
class PhysicsOptions(Options):
    goal_tolerance: float = option(
        0.02, help="how close to a goal fills it", within=GOAL_TOLERANCE, unit="metres"
    )
    realtime: bool = option(
        False,
        help="simulate at 1x wall-clock time, not flat out, streaming Scene and JointState "
        "while the arm moves as a robot does (--scene-hz, --joint-state-hz)",
    )
    scene_hz: float = option(
        30.0,
        help="with --realtime: Scene rate, also while the arm moves (a camera's rate)",
        within=STREAM_RATE,
        unit="Hz",
    )
    joint_state_hz: float = option(
        100.0,
        help="with --realtime: JointState rate while the arm moves (at most the 200 Hz "
        "physics rate)",
        within=STREAM_RATE,
        unit="Hz",
    )
    video: Path | None = option(
        None,
        help="render each episode to this .gif/.mp4 ({episode}, {seed} allowed; needs Vulkan, "
        "see scripts/install-vulkan.sh)",
    )
    camera: bool = option(
        False,
        help="render the tripod camera (ArUco markers on every body) and publish its images, "
        "intrinsics and the episode layout (needs Vulkan)",
    )
    camera_hz: float = option(
        2.0, help="camera frames per second", within=Interval(0, 60, low_open=True), unit="Hz"
    )
    camera_noise: float = option(
        0.0, help="Gaussian image noise", within=Interval(0, 64), unit="grey levels"
    )
    camera_blur: int = option(
        0, help="horizontal motion blur", within=Interval(0, 32), unit="pixels"
    )
    camera_depth: bool = option(
        False,
        help="with --camera: also render depth (a RealSense D400's noise, edge dropout, "
        "holes) and publish it; the bodies then carry no markers (docs/perception.md)",
    )
    depth_noise: float = option(
        1.0, help="depth noise, times a RealSense D400's", within=Interval(0, 10), unit="x"
    )
    camera_light: float = option(
        1.0, help="light intensity, times the default", within=Interval(0.1, 3), unit="x"
    )
    camera_offset: float = option(
        0.0,
        help="the camera stands this far off its calibrated place",
        within=Interval(0, 0.05),
        unit="metres",
    )
    camera_tilt: float = option(
        0.0,
        help="the camera is turned this far off its calibrated pose",
        within=Interval(0, 5),
        unit="degrees",
    )


BACKENDS: Registry[type[SimBackend]] = Registry("backend")
BACKENDS.add_lazy(
    "geometric",
    "manigraph_sim.geometric.backend:GeometricBackend",
    options=GeometricOptions,
    help="the fast block world with a magic gripper",
)
BACKENDS.add_lazy(
    "physics",
    "manigraph_sim.physics.backend:PhysicsBackend",
    options=PhysicsOptions,
    help="SAPIEN with a Franka Panda that follows joint trajectories",
)


def create_backend(name: str, **values: Any) -> SimBackend:
    """Backend ``name`` with ``values`` as its options (``ConfigError`` naming a bad one)."""
    options = BACKENDS.options(name, values)
    return BACKENDS[name].from_options(options)
