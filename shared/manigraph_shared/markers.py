"""Marker maps: which printed ArUco marker sits where on which object.

The same TOML file serves the sim (it prints the markers on its bodies) and perception (it
turns detected markers back into object poses); a real lab writes one for its own blocks.

```toml
dictionary = "DICT_4X4_250"      # an OpenCV predefined ArUco dictionary

[[markers]]
id = 0                           # marker id in the dictionary, each used once
object = "block_0"               # the object it is stuck on
category = "block"               # block | cover (checked against the layout)
size = 0.034                     # side of the black square, metres
face = "top"                     # top | bottom | +x | -x | +y | -y of the object's box
offset = [0.0, 0.0]              # marker centre on the face, metres (face right, face up)
attributes = { colour = "red" }  # optional: what the task tells this object apart by
```

``attributes`` (text or number values) are the object's: perception puts them on the object in
every Scene, over what the layout says, so a goal's ``accepts`` (docs/task-files.md) is judged
on what the camera identified. Markers of one object may each list them; they must agree.

Each face has a frame: ``normal`` points out of the object, ``up`` is the printed marker's
up (towards the object's +x on top and bottom, +z on the sides) and ``right = up x normal``.
The marker's own frame (OpenCV's: x right, y up, z out of the marker) is that face frame
moved to the face centre plus ``offset``.
"""

from __future__ import annotations

import json
import tomllib
from collections.abc import Iterable
from pathlib import Path
from typing import Annotated, Literal

import numpy as np
from pydantic import BaseModel, ConfigDict, Field, ValidationError, model_validator

from manigraph_shared.errors import ConfigError

#: OpenCV's predefined 4x4 .. 7x7 dictionaries (``cv2.aruco.DICT_*``) and their sizes.
DICTIONARIES = {
    f"DICT_{bits}X{bits}_{count}": count for bits in (4, 5, 6, 7) for count in (50, 100, 250, 1000)
}
Face = Literal["top", "bottom", "+x", "-x", "+y", "-y"]
AttributeName = Annotated[str, Field(pattern=r"^[a-z][a-z0-9_]{0,31}$")]
AttributeValue = (
    Annotated[str, Field(min_length=1, max_length=64)] | Annotated[float, Field(ge=-1e6, le=1e6)]
)

#: (normal, up) of each face in the object's frame.
FACE_AXES: dict[str, tuple[tuple[float, float, float], tuple[float, float, float]]] = {
    "top": ((0, 0, 1), (1, 0, 0)),
    "bottom": ((0, 0, -1), (1, 0, 0)),
    "+x": ((1, 0, 0), (0, 0, 1)),
    "-x": ((-1, 0, 0), (0, 0, 1)),
    "+y": ((0, 1, 0), (0, 0, 1)),
    "-y": ((0, -1, 0), (0, 0, 1)),
}


class _Strict(BaseModel):
    model_config = ConfigDict(extra="forbid", allow_inf_nan=False, frozen=True)


class MarkerSpec(_Strict):
    id: int = Field(ge=0, le=999)
    object: str = Field(pattern=r"^[A-Za-z0-9_.:\-]{1,64}$")
    category: Literal["block", "cover"]
    size: float = Field(gt=0.005, le=0.5, description="black square side, metres")
    face: Face = "top"
    offset: tuple[float, float] = (0.0, 0.0)
    attributes: dict[AttributeName, AttributeValue] = Field(default_factory=dict, max_length=16)


class MarkerMap(_Strict):
    dictionary: Annotated[str, Field(description="OpenCV predefined dictionary")] = "DICT_4X4_250"
    markers: list[MarkerSpec] = Field(min_length=1, max_length=1000)

    @model_validator(mode="after")
    def _consistent(self) -> MarkerMap:
        if self.dictionary not in DICTIONARIES:
            raise ValueError(f"dictionary: '{self.dictionary}' is not one of OpenCV's DICT_*")
        ids = [m.id for m in self.markers]
        twice = sorted({i for i in ids if ids.count(i) > 1})
        if twice:
            raise ValueError(f"markers: id used twice: {', '.join(map(str, twice))}")
        too_big = [i for i in ids if i >= DICTIONARIES[self.dictionary]]
        if too_big:
            raise ValueError(f"markers: id {too_big[0]} is not in {self.dictionary}")
        categories: dict[str, str] = {}
        for marker in self.markers:
            if categories.setdefault(marker.object, marker.category) != marker.category:
                raise ValueError(f"markers: object '{marker.object}' has two categories")
        attributes: dict[str, dict[str, str | float]] = {}
        for marker in self.markers:
            known = attributes.setdefault(marker.object, {})
            for name, value in marker.attributes.items():
                if known.setdefault(name, value) != value:
                    raise ValueError(
                        f"markers: object '{marker.object}' has two values of {name} "
                        f"({known[name]!r} and {value!r}, marker {marker.id})"
                    )
        return self

    def attributes_of(self, object_id: str) -> dict[str, str | float]:
        """The attributes the markers of ``object_id`` give it (empty if none)."""
        merged: dict[str, str | float] = {}
        for marker in self.for_object(object_id):
            merged.update(marker.attributes)
        return merged

    def by_id(self) -> dict[int, MarkerSpec]:
        return {m.id: m for m in self.markers}

    def for_object(self, object_id: str) -> list[MarkerSpec]:
        return [m for m in self.markers if m.object == object_id]

    def check_objects(self, objects: Iterable[tuple[str, str]]) -> None:
        """Raise ``ConfigError`` naming the first (id, category) object with no marker or a
        marker of another category."""
        for object_id, category in objects:
            markers = self.for_object(object_id)
            if not markers:
                raise ConfigError(f"markers.{object_id}", "the layout's object has no marker")
            if markers[0].category != category:
                raise ConfigError(
                    f"markers.{object_id}",
                    f"is a {markers[0].category} in the marker map, a {category} in the layout",
                )

    def to_toml(self) -> str:
        lines = [f'dictionary = "{self.dictionary}"', ""]
        for m in self.markers:
            lines += [
                "[[markers]]",
                f"id = {m.id}",
                f'object = "{m.object}"',
                f'category = "{m.category}"',
                f"size = {m.size}",
                f'face = "{m.face}"',
                f"offset = [{m.offset[0]}, {m.offset[1]}]",
                *([f"attributes = {{ {_inline(m.attributes)} }}"] if m.attributes else []),
                "",
            ]
        return "\n".join(lines)


def _inline(attributes: dict[str, str | float]) -> str:
    return ", ".join(
        f"{name} = {json.dumps(value) if isinstance(value, str) else repr(float(value))}"
        for name, value in attributes.items()
    )


def parse_marker_map(text: str, source: str = "marker map") -> MarkerMap:
    """Validate a marker map's TOML; ``ConfigError`` names the line or the field."""
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise ConfigError(source, str(exc)) from None
    try:
        return MarkerMap.model_validate(data)
    except ValidationError as exc:
        error = exc.errors(include_url=False)[0]
        field = ".".join(str(part) for part in error["loc"]) or "<file>"
        raise ConfigError(
            f"{source}: {field}", error["msg"].removeprefix("Value error, ")
        ) from None


def load_marker_map(path: str | Path) -> MarkerMap:
    try:
        text = Path(path).read_text()
    except OSError as exc:
        raise ConfigError("markers", f"cannot read '{path}': {exc.strerror}") from None
    return parse_marker_map(text, f"markers '{path}'")


def marker_in_object(marker: MarkerSpec, object_size: np.ndarray) -> np.ndarray:
    """The 4 x 4 pose of ``marker``'s frame in its object's frame (centre of the object)."""
    normal, up = (np.array(v, dtype=float) for v in FACE_AXES[marker.face])
    right = np.cross(up, normal)
    depth = float(np.abs(normal) @ np.asarray(object_size, dtype=float)) / 2
    pose = np.eye(4)
    pose[:3, :3] = np.stack([right, up, normal], axis=1)
    pose[:3, 3] = normal * depth + right * marker.offset[0] + up * marker.offset[1]
    return pose


def marker_corners(size: float) -> np.ndarray:
    """The marker's 4 corners in its own frame, in OpenCV's order (top-left, top-right,
    bottom-right, bottom-left as printed)."""
    h = size / 2
    return np.array([[-h, h, 0.0], [h, h, 0.0], [h, -h, 0.0], [-h, -h, 0.0]])


#: The sim's printed markers: a 3.4 cm marker on five faces of every 4 cm block (not the
#: bottom) and four 6 cm markers round the handle of every cover.
SIM_BLOCK_MARKER = 0.034
SIM_COVER_MARKER = 0.06
SIM_BLOCKS = 40
SIM_COVERS = 5
_SIM_BLOCK_FACES: tuple[Face, ...] = ("top", "+x", "-x", "+y", "-y")
_SIM_COVER_OFFSETS = ((0.07, 0.07), (-0.07, 0.07), (-0.07, -0.07), (0.07, -0.07))


def sim_marker_map() -> MarkerMap:
    """The marker map of every object the sim's tasks lay out (``block_0`` .. ``block_39``,
    ``cover_0`` .. ``cover_4``); committed as ``examples/markers/sim.toml``."""
    markers: list[MarkerSpec] = []
    for block in range(SIM_BLOCKS):
        for face in _SIM_BLOCK_FACES:
            markers.append(
                MarkerSpec(
                    id=len(markers),
                    object=f"block_{block}",
                    category="block",
                    size=SIM_BLOCK_MARKER,
                    face=face,
                )
            )
    for cover in range(SIM_COVERS):
        for offset in _SIM_COVER_OFFSETS:
            markers.append(
                MarkerSpec(
                    id=len(markers),
                    object=f"cover_{cover}",
                    category="cover",
                    size=SIM_COVER_MARKER,
                    offset=offset,
                )
            )
    return MarkerMap(dictionary="DICT_4X4_250", markers=markers)
