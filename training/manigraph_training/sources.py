"""Where demonstrations come from: each kind of path ``manigraph train`` takes, registered.

A source is a test (is this path mine?) and a reader yielding the path's ``Scene`` and
``Action`` messages in order; :func:`read_source` gives a path to the first source that claims
it. An MCAP log claims any other path, so a missing file is refused as before (``LogError``).
Readers are imported when used, so training from logs never imports the LeRobot reader.
"""

from __future__ import annotations

import importlib
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import cast

from manigraph_shared.errors import LogError
from manigraph_shared.mcap_log import read_log
from manigraph_shared.messages import Action, Scene
from manigraph_shared.registry import Registry

Reader = Callable[[Path], Iterator[Scene | Action]]


@dataclass(frozen=True)
class DemoSource:
    """``claims(path)``: the path is this source's; ``reader``: ``"module:function"``."""

    claims: Callable[[Path], bool]
    reader: str

    def read(self, path: Path) -> Iterator[Scene | Action]:
        module, _, name = self.reader.partition(":")
        return cast(Reader, getattr(importlib.import_module(module), name))(path)


def read_mcap(path: Path) -> Iterator[Scene | Action]:
    """The scenes and actions of an MCAP log, in file order."""
    if not path.is_file():
        raise LogError(f"demonstrations: no such file: {path}")
    for item in read_log(path, [Scene.key, Action.key]):
        message = item.decode()
        if isinstance(message, Scene | Action):
            yield message


def _is_lerobot(path: Path) -> bool:
    return path.is_dir() and (path / "meta" / "info.json").is_file()


#: Sources in the order they are asked; the MCAP log last, claiming every other path.
SOURCES: Registry[DemoSource] = Registry("demonstration source")
SOURCES.add(
    "lerobot",
    DemoSource(_is_lerobot, "manigraph_training.lerobot_source:read_lerobot"),
    help="a LeRobot v3 dataset written by manigraph export --format lerobot",
)
SOURCES.add(
    "mcap",
    DemoSource(lambda _path: True, "manigraph_training.sources:read_mcap"),
    help="an MCAP log with scenes and actions",
)


def read_source(path: Path) -> Iterator[Scene | Action]:
    """The scenes and actions of ``path``, read by the first source that claims it."""
    for _name, source in SOURCES.items():
        if source.claims(path):
            return source.read(path)
    raise LogError(f"demonstrations: no source reads {path}")  # unreachable: mcap claims all
