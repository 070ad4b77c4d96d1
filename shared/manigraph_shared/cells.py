"""Robot cells: one world, its skills and its robot under their own key prefix.

A message's key is declared once, for the default cell (``manigraph/world/scene``). In a cell
named ``left`` the same message travels on ``manigraph/left/world/scene``: the cell is the
key's second segment, so one bus (one router, or routers joined across hosts) carries any
number of cells without cross-talk, and a recording says which cell each message came from
by its channel. The default cell has no segment, so today's keys, stacks and logs are
unchanged. :class:`~manigraph_shared.bus.Bus` applies the cell to every key it is given.
"""

from __future__ import annotations

import re

from manigraph_shared.errors import ConfigError

__all__ = [
    "CELL_SEGMENT",
    "EVERY_CELL",
    "PREFIX",
    "RESERVED",
    "cell_key",
    "cell_names",
    "cell_of",
    "cell_pattern",
    "check_cell",
    "check_cells",
    "default_key",
]

PREFIX = "manigraph"
#: The second segments of the default cell's keys: no cell may be named like them.
RESERVED = frozenset({"world", "planner", "robot", "skills", "camera", "status", "alive", "cells"})
_NAME = re.compile(r"[a-z0-9][a-z0-9_-]{0,31}")
#: How the docs and the manifests write a key's cell segment: ``manigraph/<cell>/world/scene``.
CELL_SEGMENT = "<cell>"
#: The one bus-wide key expression: every cell's messages, the default cell's included. Read
#: by an observer in the default cell (``manigraph record``, ``manigraph view``) and relayed
#: from router to router; every other key (messages, heartbeats, liveliness) is per cell.
EVERY_CELL = f"{PREFIX}/**"


def check_cell(name: str) -> str:
    """``name`` if it can name a cell, else a ``ConfigError`` naming the field ``cell``."""
    if not _NAME.fullmatch(name):
        raise ConfigError(
            "cell",
            f"'{name}' is not a cell name: 1-32 of a-z, 0-9, '-', '_', a letter or digit first",
        )
    if name in RESERVED:
        raise ConfigError(
            "cell", f"'{name}' is a key segment of its own ({', '.join(sorted(RESERVED))})"
        )
    return name


def cell_key(key: str, cell: str | None) -> str:
    """``key`` (a default-cell key or pattern) in ``cell``; unchanged for the default cell
    (``None``) and for keys outside ``manigraph/``."""
    if cell is None:
        return key
    head, sep, rest = key.partition("/")
    if head != PREFIX or not sep:
        return key
    return f"{PREFIX}/{cell}/{rest}"


def cell_pattern(key: str) -> str:
    """``key`` (a default-cell key) as the docs and manifests show a per-cell key:
    ``manigraph/world/scene`` -> ``manigraph/<cell>/world/scene`` (the default cell drops
    ``<cell>/``)."""
    return cell_key(key, CELL_SEGMENT)


def cell_of(key: str) -> str | None:
    """The cell a concrete key belongs to (``None``: the default cell)."""
    parts = key.split("/")
    if len(parts) < 3 or parts[0] != PREFIX or parts[1] in RESERVED:
        return None
    return parts[1]


def default_key(key: str) -> str:
    """A concrete key of any cell as the default cell's (where its type is declared):
    ``manigraph/left/world/scene`` -> ``manigraph/world/scene``."""
    cell = cell_of(key)
    return key if cell is None else f"{PREFIX}/{key.split('/', 2)[2]}"


def check_cells(names: list[str]) -> list[str]:
    """``names`` if each can name a cell and none repeats, else a ``ConfigError`` (``cells``)."""
    if not names:
        raise ConfigError("cells", "name at least one cell")
    for name in names:
        try:
            check_cell(name)
        except ConfigError as exc:
            raise ConfigError("cells", exc.problem) from None
    repeated = sorted({name for name in names if names.count(name) > 1})
    if repeated:
        raise ConfigError("cells", f"named twice: {', '.join(repeated)}")
    return names


def cell_names(count: int) -> list[str]:
    """The names ``manigraph up --cells N`` gives its cells: ``cell-1`` to ``cell-N``."""
    if count < 1:
        raise ConfigError("cells", "must be >= 1")
    return [f"cell-{i}" for i in range(1, count + 1)]
