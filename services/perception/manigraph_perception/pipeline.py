"""What every perception pipeline is to the one service that runs it (``service.py``).

A pipeline turns camera frames into a ``Scene``. The service does the rest, once for all of
them: the bus, the frame's parts paired by ``sequence`` and checked from their headers, the
newest frame first, health, the layout, the robot's actions and gripper, and what a stale
camera means (below). A pipeline lives in ``pipelines/<name>/`` and is registered by name in
``registry.py``; ``manigraph perception --pipeline NAME`` looks it up there.

A pipeline (:class:`Pipeline`) declares the camera messages one frame is made of
(``parts``: ArUco a ``CompressedImage``, RGB-D that and a ``DepthImage`` of the same
sequence), checks each from its header (``check``), decodes a whole frame (``assemble``) and
observes it (``observe``): the Scene, or None with the reason it cannot give one yet, and any
other messages it publishes (ArUco's ``MarkerDetections``). A frame it cannot use raises
:class:`BadFrame` naming why; ``observe`` counts its own, the service counts the rest.

**A stale camera** is handled by the service for every pipeline alike (issue 50): the
planner decides only on a Scene observed after its last skill ended, so a Scene is made only
from a new frame. A frame that cannot be used and a frame no newer than the last one used (a
frozen camera) are named in the service's status with the age of the last good Scene, and
that Scene is published again, ``stale``, with its own (old) stamp, at most once a second:
every reader sees the camera is not seeing, and the planner, which needs a newer stamp, never
acts on it. No usable frame for ``--stale-after`` seconds is named in the status (with that
age, and the last frame refused).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any, Protocol, TypeAlias, TypeVar

from manigraph_shared.messages import CompressedImage, DepthImage, Message, Scene, TaskLayout

if TYPE_CHECKING:  # imports nothing heavy: the command's --help reads the registry
    from manigraph_perception.calibration_file import Calibration
    from manigraph_perception.image_guard import ImageProblem
    from manigraph_perception.world_belief import WorldConfig, WorldModel

#: This many failed reads in a row and a camera source is declared gone.
MAX_FAILED_READS = 50

#: A camera message a frame is made of.
CameraPart: TypeAlias = CompressedImage | DepthImage


class BadFrame(ValueError):
    """A frame a pipeline cannot use; ``kind`` names its counter (``no_plane``, ``corrupt``)."""

    def __init__(self, kind: str, reason: str) -> None:
        super().__init__(reason)
        self.kind = kind


@dataclass
class FrameCounters:
    """What every pipeline counts for the status; a pipeline adds its own kinds as fields."""

    frames: int = 0
    stale: int = 0
    #: Parts of frames let go without the rest of their frame (``pairing.py``).
    unpaired: int = 0

    def count(self, kind: str) -> None:
        """One more frame refused as ``kind`` (a field of the pipeline's counters)."""
        setattr(self, kind, getattr(self, kind) + 1)

    def summary(self) -> str:
        return f"frames {self.frames}, stale {self.stale}"


class Frame(Protocol):
    """One frame, decoded: what ``observe`` takes."""

    @property
    def stamp(self) -> float: ...

    @property
    def sequence(self) -> int: ...


FrameT = TypeVar("FrameT", bound=Frame)
FrameT_co = TypeVar("FrameT_co", bound=Frame, covariant=True)


@dataclass
class Observation:
    """What one frame gave: the Scene (None: ``waiting`` says why not yet, if anything does)
    and the other messages to publish before it."""

    scene: Scene | None
    messages: list[Message] = field(default_factory=list)
    waiting: str = ""


class Pipeline(Protocol[FrameT]):
    """Camera frames in, a Scene out; no bus (the service wires it)."""

    camera: str
    calibration: Calibration
    world: WorldModel

    @property
    def counters(self) -> FrameCounters: ...

    @property
    def parts(self) -> Mapping[str, type[CameraPart]]:
        """The messages one frame is made of, by the last segment of their key
        (``manigraph/camera/<camera>/<part>``)."""
        ...

    @property
    def layout(self) -> TaskLayout | None: ...

    def set_layout(self, layout: TaskLayout) -> None:
        """Take an episode's layout (again: nothing); ``ConfigError`` if it cannot be seen."""

    def check(self, part: str, data: bytes) -> ImageProblem | None:
        """Why ``data`` cannot be this frame part, from its header alone (None: it can)."""

    def assemble(self, parts: Mapping[str, CameraPart]) -> FrameT:
        """A whole frame's parts, decoded; ``BadFrame`` naming why not (not counted)."""
        ...

    def observe(self, frame: FrameT, now: float) -> Observation:
        """One frame; ``BadFrame`` (counted) if it cannot be used."""
        ...


class FrameSource(Protocol[FrameT_co]):
    """Frames from a device or a file, not the bus."""

    def read(self) -> FrameT_co | None:
        """The next frame, None for none yet, ``BadFrame`` for one that cannot be used;
        ``ConfigError`` once the source has stopped."""
        ...

    def close(self) -> None: ...


@dataclass(frozen=True)
class CameraSetup:
    """What every pipeline is opened with (the flags all of them take)."""

    camera: str  # 'bus', or a device, file or URL the pipeline's source reads
    camera_name: str
    calibration: Calibration
    world: WorldConfig
    layout_path: str | None = None


@dataclass
class OpenedPipeline:
    """A pipeline ready to run: its frames from ``source`` (None: the bus); ``layout``: a
    fixed one from a file (None: the sim's, from the bus)."""

    pipeline: Pipeline[Any]
    source: FrameSource[Any] | None = None
    layout: TaskLayout | None = None


@dataclass(frozen=True)
class PipelineUnit:
    """A registered pipeline: the messages its frames are made of and the others it
    publishes (its manifest variant declares both), and how it is opened from its options."""

    parts: Mapping[str, type[CameraPart]]
    produces: tuple[type[Message], ...]
    open: Callable[[Any, CameraSetup], OpenedPipeline]
