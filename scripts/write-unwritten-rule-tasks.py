"""Write examples/tasks/unwritten/: five kinds of rule that no task file states.

Each kind is a task file with no rule (its goals accept any block) and a rules file that only
the teacher and the judge read (``--rules``, docs/task-files.md), at the size demonstrated and
at twice and three times the objects. Run from the repository root:

    uv run python scripts/write-unwritten-rule-tasks.py
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

OUT = Path("examples/tasks/unwritten")
#: Where objects start: one of these per object and seed, 9-11 cm apart, none taken twice.
SPOTS = [(x, round(-0.55 + 0.11 * i, 2), 0.0) for x in (0.30, 0.39, 0.48) for i in range(11)]
#: The spots the physics sim's tripod camera sees whole (|y| <= 0.33; tests/physics/
#: test_camera_view.py): the starts of the files perception must find by sight.
CAMERA_SPOTS = [spot for spot in SPOTS if abs(spot[1]) <= 0.33]
CUBE = (0.04, 0.04, 0.04)
FLAT = (0.07, 0.07, 0.02)


def _vec(values: tuple[float, ...] | list[float]) -> str:
    return "[" + ", ".join(f"{v:g}" for v in values) + "]"


def _value(value: object) -> str:
    return f'"{value}"' if isinstance(value, str) else _vec(value)  # type: ignore[arg-type]


def _table(values: dict[str, object]) -> str:
    return "{ " + ", ".join(f"{k} = {_value(v)}" for k, v in values.items()) + " }"


def _object(
    name: str,
    index: int,
    size: tuple[float, float, float],
    among: list[tuple[float, float, float]] = SPOTS,
    **extra: object,
) -> str:
    """An object choosing among ``among`` (:data:`SPOTS`), listed from its own (``index``) on:
    the first listed is where a file without draws would put it, and two objects never share
    it."""
    turned = among[index:] + among[:index]
    spots = [(x, y, size[2] / 2) for x, y, _ in turned]
    rows = [", ".join(_vec(s) for s in spots[i : i + 4]) for i in range(0, len(spots), 4)]
    lines = [
        "[[objects]]",
        f'id = "{name}"',
        'category = "block"',
        f"size = {_vec(size)}",
        "positions = [  # one drawn per seed, none taken twice",
        *(f"    {row}," for row in rows),
        "]",
        "jitter = 0.01",
    ]
    for key, value in extra.items():
        lines.append(f"{key} = {_table(value) if isinstance(value, dict) else str(value).lower()}")
    return "\n".join(lines) + "\n"


def _goal(name: str, position: tuple[float, float, float], **extra: object) -> str:
    lines = ["[[goals]]", f'id = "{name}"', 'category = "block"', f"position = {_vec(position)}"]
    lines += [f"{key} = {_table(value)}" for key, value in extra.items()]  # type: ignore[arg-type]
    return "\n".join(lines) + "\n"


def _rule(name: str, accepts: dict[str, object]) -> str:
    return f'[[goals]]\nid = "{name}"\naccepts = {_table(accepts)}\n'


def _bins(
    per_side: int,
) -> tuple[list[tuple[float, float, float]], list[tuple[float, float, float]]]:
    """Goals on the left (y > 0) and on the right, rows of three from the near one out."""

    def side(sign: float) -> list[tuple[float, float, float]]:
        return [
            (round(0.62 + 0.08 * (k // 3), 2), round(sign * (0.08 + 0.07 * (k % 3)), 2), 0.02)
            for k in range(per_side)
        ]

    return side(1.0), side(-1.0)


Family = Callable[[int], tuple[str, str, str]]


def colour_place(n: int, among: list[tuple[float, float, float]] = SPOTS) -> tuple[str, str, str]:
    left, right = _bins(n // 2)
    head = (
        f"# Colour to a place, {n} blocks: half red, half blue (which is which shuffled per\n"
        "# seed), and as many bins, half on the left, half on the right. The file states no\n"
        "# rule: any block fills any bin. The rules file (red to the left, blue to the right)\n"
        "# is the teacher's and the judge's alone.\n\n"
        f'name = "colour to a place {n}"\nrandomize_xy = 0.02\nshuffle = ["colour"]\n\n'
    )
    body = "".join(
        _object(
            f"block_{i}", i, CUBE, among, attributes={"colour": "red" if i < n // 2 else "blue"}
        )
        + "\n"
        for i in range(n)
    )
    body += "".join(_goal(f"left_{k}", p) + "\n" for k, p in enumerate(left))
    body += "".join(_goal(f"right_{k}", p) + "\n" for k, p in enumerate(right))
    rules = f"# Red blocks to the left bins, blue to the right ({n} blocks).\n\n"
    rules += "\n".join(_rule(f"left_{k}", {"colour": "red"}) for k in range(len(left)))
    rules += "\n" + "\n".join(_rule(f"right_{k}", {"colour": "blue"}) for k in range(len(right)))
    return "colour-place", head + body, rules


def same_colour(n: int) -> tuple[str, str, str]:
    left, right = _bins(n // 2)
    head = (
        f"# Same colour as the bin, {n} blocks: half red, half blue, and as many bins, each\n"
        "# with a colour of its own; both shuffled per seed, the blocks' and the bins'\n"
        "# separately. The file states no rule: any block fills any bin. The rules file\n"
        "# (same = [\"colour\"]) is the teacher's and the judge's alone.\n\n"
        f'name = "same colour as the bin {n}"\nrandomize_xy = 0.02\nshuffle = ["colour"]\n\n'
    )
    body = "".join(
        _object(
            f"block_{i}", i, CUBE, SPOTS, attributes={"colour": "red" if i < n // 2 else "blue"}
        )
        + "\n"
        for i in range(n)
    )
    goals = left + right
    body += "".join(
        _goal(f"bin_{k}", p, attributes={"colour": "red" if k < n // 2 else "blue"}) + "\n"
        for k, p in enumerate(goals)
    )
    rules = f'# Each block into a bin of its own colour ({n} blocks).\n\nsame = ["colour"]\n'
    return "same-colour", head + body, rules


def size_tower(levels: int) -> tuple[str, str, str]:
    widths = [round(0.07 - 0.005 * k, 3) for k in range(levels)]
    head = (
        f"# Size order in a tower, {levels} blocks of widths {widths[-1] * 100:g}-"
        f"{widths[0] * 100:g} cm (all 4 cm high)\n"
        "# and a tower of as many levels. The file states no rule: any block fills any\n"
        "# level. The rules file (largest at the bottom) is the teacher's and the judge's.\n\n"
        f'name = "size-ordered tower {levels}"\nrandomize_xy = 0.02\n\n'
    )
    # Ids in no size order (smallest first): an id is no hint of where a block goes.
    body = "".join(
        _object(f"block_{i}", i, (w, w, 0.04)) + "\n" for i, w in enumerate(reversed(widths))
    )
    body += "".join(
        _goal(f"level_{k}", (0.66, 0.0, round(0.02 + 0.04 * k, 2))) + "\n" for k in range(levels)
    )
    rules = f"# Largest at the bottom, each level one size smaller ({levels} levels).\n\n"
    rules += "\n".join(_rule(f"level_{k}", {"size": [w, w, 0.04]}) for k, w in enumerate(widths))
    return "size-tower", head + body, rules


def red_only_tower(n: int) -> tuple[str, str, str]:
    levels = n // 2
    head = (
        f"# Only red in the tower, {n} blocks: {levels} red, {levels} blue distractors (spares),\n"
        f"# and a tower of {levels} levels. The file states no rule: any block fills any level.\n"
        "# The rules file (only red) is the teacher's and the judge's alone.\n\n"
        f'name = "only red in the tower {n}"\nrandomize_xy = 0.02\n\n'
    )
    body = "".join(
        _object(
            f"block_{i}",
            i,
            CUBE,
            attributes={"colour": "red" if i % 2 == 0 else "blue"},  # ids alternate
            **({"spare": True} if i % 2 else {}),
        )
        + "\n"
        for i in range(n)
    )
    body += "".join(
        _goal(f"tower_{k}", (0.66, 0.0, round(0.02 + 0.04 * k, 2))) + "\n" for k in range(levels)
    )
    rules = f"# Only red blocks in the tower ({levels} levels).\n\n"
    rules += "\n".join(_rule(f"tower_{k}", {"colour": "red"}) for k in range(levels))
    return "red-only-tower", head + body, rules


def flat_back(n: int) -> tuple[str, str, str]:
    half = n // 2
    head = (
        f"# Big flat objects to the back row, {n} objects: {half} flat 7 x 7 x 2 cm, {half}\n"
        f"# 4 cm cubes, and {half} goals in a back row and {half} in a front row. The file states\n"
        "# no rule: any object fills any goal. The rules file (flat ones at the back, cubes in\n"
        "# front) is the teacher's and the judge's alone.\n\n"
        f'name = "big flat to the back {n}"\nrandomize_xy = 0.02\n\n'
    )
    # Flat objects and cubes stand at heights of their own: they draw from spots of their own.
    body = "".join(_object(f"flat_{i}", i, FLAT, SPOTS[0::2]) + "\n" for i in range(half))
    body += "".join(_object(f"cube_{i}", i, CUBE, SPOTS[1::2]) + "\n" for i in range(half))
    back = [(0.74, round(0.09 * (k - (half - 1) / 2), 3), 0.01) for k in range(half)]
    front = [(0.62, round(0.07 * (k - (half - 1) / 2), 3), 0.02) for k in range(half)]
    body += "".join(_goal(f"back_{k}", p) + "\n" for k, p in enumerate(back))
    body += "".join(_goal(f"front_{k}", p) + "\n" for k, p in enumerate(front))
    rules = f"# Flat objects to the back row, cubes to the front ({n} objects).\n\n"
    rules += "\n".join(_rule(f"back_{k}", {"size": list(FLAT)}) for k in range(half))
    rules += "\n" + "\n".join(_rule(f"front_{k}", {"size": list(CUBE)}) for k in range(half))
    return "flat-back", head + body, rules


#: Each kind at the size demonstrated, then twice and three times the objects.
SIZES: dict[Family, tuple[int, int, int]] = {
    colour_place: (4, 8, 12),
    same_colour: (4, 8, 12),
    size_tower: (3, 6, 9),
    red_only_tower: (4, 8, 12),
    flat_back: (4, 8, 12),
}


def colour_place_camera() -> tuple[str, str, str]:
    """Colour place at 4 blocks, every start where the physics sim's tripod camera sees it:
    for the closed loop with RGB-D perception as the only scene source."""
    stem, task, rules = colour_place(4, CAMERA_SPOTS)
    head = (
        "# For a camera: colour-place.toml with every start where the physics sim's tripod\n"
        "# camera sees the block whole (|y| <= 0.33), for RGB-D perception as the only scene\n"
        "# source (docs/perception.md). Its rules are colour-place's.\n"
    )
    return (
        f"{stem}-camera",
        head + task.replace('"colour to a place 4"', '"colour to a place 4, camera"'),
        rules,
    )


def _write(name: str, task: str, rules: str) -> None:
    (OUT / f"{name}.toml").write_text(task.rstrip() + "\n")
    (OUT / f"{name}.rules.toml").write_text(rules.rstrip() + "\n")


def main() -> None:
    OUT.mkdir(parents=True, exist_ok=True)
    for family, sizes in SIZES.items():
        for rank, n in enumerate(sizes):
            stem, task, rules = family(n)
            _write(stem if rank == 0 else f"{stem}-{n}", task, rules)
    _write(*colour_place_camera())


if __name__ == "__main__":
    main()
