"""What a goal's ``accepts`` admits: the one rule every world, perception and expert applies.

A goal lists what an object must carry to fill it (``SceneGoal.accepts``,
``LayoutGoal.accepts``): every key must match. ``id`` names the object itself, ``size`` its
full extents (within :data:`SIZE_TOLERANCE` on each axis), any other key an attribute whose
value must be equal (numbers within 1e-9). An empty ``accepts`` admits any object of the goal's
category, as before attributes existed.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

#: Sizes match within this, metres, on each axis.
SIZE_TOLERANCE = 1e-3

AttributeValue = str | float
AcceptValue = str | float | Sequence[float]


def admits(
    accepts: Mapping[str, AcceptValue],
    object_id: str,
    size: Sequence[float],
    attributes: Mapping[str, AttributeValue],
) -> bool:
    """Whether a goal with ``accepts`` admits the object (its category is checked elsewhere)."""
    return refusal(accepts, object_id, size, attributes) is None


def refusal(
    accepts: Mapping[str, AcceptValue],
    object_id: str,
    size: Sequence[float],
    attributes: Mapping[str, AttributeValue],
) -> str | None:
    """Why the goal refuses the object (the first key that does not match), or None."""
    for key, wanted in accepts.items():
        if key == "id":
            if object_id != wanted:
                return f"id {object_id} is not {wanted}"
        elif key == "size":
            if isinstance(wanted, str | int | float) or len(wanted) != 3:
                return f"size: {wanted!r} is not [x, y, z]"
            if any(
                abs(float(a) - float(b)) > SIZE_TOLERANCE for a, b in zip(size, wanted, strict=True)
            ):
                return f"size {_vector(size)} is not {_vector(wanted)}"
        else:
            have = attributes.get(key)
            if have is None:
                return f"has no {key}"
            if not _equal(have, wanted):
                return f"{key} {have} is not {wanted}"
    return None


def _equal(have: AttributeValue, wanted: AcceptValue) -> bool:
    if isinstance(have, str) or isinstance(wanted, str):
        return have == wanted
    if not isinstance(wanted, int | float):
        return False
    return abs(float(have) - float(wanted)) <= 1e-9


def _vector(values: Sequence[float]) -> str:
    return "[" + ", ".join(f"{float(v):g}" for v in values) + "]"
