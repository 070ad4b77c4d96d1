"""A real lab's layout: a TOML file in the task file's format (``[[objects]]`` with id,
category, position, size, attributes; ``[[goals]]`` with id, category, position, optional,
accepts;
``[[containers]]`` with id, centre, inner, height; ``partially_observable``), read into the
contract's ``TaskLayout``. See docs/perception.md."""

from __future__ import annotations

import time
import tomllib
from pathlib import Path
from typing import Any

from manigraph_shared.errors import ConfigError, MessageError
from manigraph_shared.messages import TaskLayout


def _xyz(values: list[float], default_z: float = 0.0) -> dict[str, float]:
    x, y, *rest = values
    return {"x": x, "y": y, "z": rest[0] if rest else default_z}


def _start(o: dict[str, Any], positions: bool) -> dict[str, float]:
    """An object's starting position: ``position``, else the first of a task file's
    ``positions``; with ``positions`` False (the RGB-D pipeline's appearance identity, which
    strips them) neither is needed and a missing one reads as the origin."""
    if "position" in o:
        return _xyz(o["position"])
    if o.get("positions"):
        return _xyz(o["positions"][0])
    if positions:
        raise KeyError("position")
    return _xyz([0.0, 0.0, 0.0])


def load_layout(path: str | Path, episode_id: str = "live", positions: bool = True) -> TaskLayout:
    """The layout of ``path``; ``positions`` False: objects may leave their position out."""
    try:
        data = tomllib.loads(Path(path).read_text())
    except OSError as exc:
        raise ConfigError("layout", f"cannot read '{path}': {exc.strerror}") from None
    except tomllib.TOMLDecodeError as exc:
        raise ConfigError("layout", f"'{path}': {exc}") from None
    try:
        objects = [
            {
                "id": o["id"],
                "category": o["category"],
                "position": _start(o, positions),
                "size": _xyz(o.get("size", [0.04, 0.04, 0.04])),
                "attributes": o.get("attributes", {}),
            }
            for o in data.get("objects", [])
        ]
        goals = [
            {
                "id": g["id"],
                "category": g["category"],
                "position": _xyz(g["position"]),
                "optional": g.get("optional", False),
                "accepts": g.get("accepts", {}),
            }
            for g in data.get("goals", [])
        ]
        containers = [
            {
                "id": c["id"],
                "centre": _xyz(c["centre"]),
                "inner": _xyz(c["inner"], c.get("height", 0.06)),
            }
            for c in data.get("containers", [])
        ]
    except (KeyError, TypeError, ValueError) as exc:
        raise ConfigError("layout", f"'{path}': missing or malformed entry {exc}") from None
    try:
        return TaskLayout.from_builtins(
            {
                "episode_id": episode_id,
                "stamp": time.time(),
                "objects": objects,
                "goals": goals,
                "containers": containers,
                "partially_observable": data.get("partially_observable", False),
            }
        )
    except MessageError as exc:
        field, why = exc.problems[0]
        raise ConfigError(f"layout.{field}", why) from None
