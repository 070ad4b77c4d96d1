"""The perception pipelines, registered by name with their options.

Imports no pipeline: ``manigraph perception --help`` lists every pipeline's flags from the
options here, and a pipeline's folder is imported only when it is opened. Register a new one
(``pipelines/<name>/unit.py`` holding a :class:`~manigraph_perception.pipeline.PipelineUnit`)
with its options dataclass::

    PIPELINES.add_lazy("mine", "manigraph_perception.pipelines.mine.unit:UNIT",
                       options=MineOptions, help="...")

and name it among the variants of the service's manifest (``manifest.py``).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, Literal

from manigraph_shared.options import Options, option
from manigraph_shared.registry import Registry

if TYPE_CHECKING:
    from manigraph_perception.pipeline import CameraSetup, OpenedPipeline, PipelineUnit

__all__ = ["PIPELINES", "ArucoOptions", "RgbdOptions", "open_pipeline"]


@dataclass(frozen=True)
class ArucoOptions(Options):
    markers: str | None = option(
        None, help="marker map TOML (docs/perception.md), or 'sim' for the sim's printed markers"
    )


@dataclass(frozen=True)
class RgbdOptions(Options):
    identity: Literal["appearance", "prior"] = option(
        "appearance",
        help="how an object is first told apart. appearance: the layout's starting positions "
        "are not used; each object is found by its colour and size. prior: matched by "
        "distance from its starting position (the old behaviour)",
    )


PIPELINES: Registry[PipelineUnit] = Registry("pipeline")
PIPELINES.add_lazy(
    "aruco",
    "manigraph_perception.pipelines.aruco.unit:UNIT",
    options=ArucoOptions,
    help="markers on the objects",
)
PIPELINES.add_lazy(
    "rgbd",
    "manigraph_perception.pipelines.rgbd.unit:UNIT",
    options=RgbdOptions,
    help="colour + depth, no markers (table plane, segmentation, colour; docs/perception.md)",
)


def open_pipeline(name: str, setup: CameraSetup, **values: Any) -> OpenedPipeline:
    """Pipeline ``name`` opened on ``setup`` with ``values`` as its options (``ConfigError``
    naming an unknown pipeline or a bad option)."""
    options = PIPELINES.options(name, values)
    return PIPELINES[name].open(options, setup)
