"""The named colours a task may give its objects, and the RGB every view draws them in.

A task file's ``attributes = { colour = "red" }`` is text to the policy (one category of a
one-hot); the physics world paints the body that colour, the views draw it, and an RGB-D
camera's objects are named after the nearest entry here. ``#rrggbb`` is read as itself.
"""

from __future__ import annotations

from collections.abc import Mapping

#: Name -> (r, g, b) in [0, 1]: saturated enough to tell apart in a rendered frame.
PALETTE: dict[str, tuple[float, float, float]] = {
    "red": (0.85, 0.12, 0.10),
    "green": (0.15, 0.65, 0.20),
    "blue": (0.12, 0.30, 0.85),
    "yellow": (0.95, 0.85, 0.10),
    "orange": (0.98, 0.50, 0.05),
    "purple": (0.55, 0.20, 0.70),
    "white": (0.92, 0.92, 0.92),
    "black": (0.08, 0.08, 0.08),
    "grey": (0.50, 0.50, 0.50),
}
#: The attribute names read as a colour (either spelling).
COLOUR_KEYS = ("colour", "color")


def rgb(value: object) -> tuple[float, float, float] | None:
    """The RGB of a palette name or ``#rrggbb``; None for anything else."""
    if not isinstance(value, str):
        return None
    name = value.strip().lower()
    if name in PALETTE:
        return PALETTE[name]
    if len(name) == 7 and name.startswith("#"):
        try:
            r, g, b = (int(name[i : i + 2], 16) / 255 for i in (1, 3, 5))
        except ValueError:
            return None
        return (r, g, b)
    return None


def colour_of(attributes: Mapping[str, object]) -> tuple[float, float, float] | None:
    """The RGB an object's attributes name (``colour`` or ``color``), or None."""
    for key in COLOUR_KEYS:
        found = rgb(attributes.get(key))
        if found is not None:
            return found
    return None


def describe(attributes: Mapping[str, object]) -> str:
    """``colour red, label bolt``: attributes as a reader sees them (empty: "")."""
    return ", ".join(
        f"{name} {value:g}" if isinstance(value, float) else f"{name} {value}"
        for name, value in attributes.items()
    )
