"""Task files built to cost the sim as much as their size allows (issue 48), for tests and
``bench/bench_hostile_task_files.py``.

:func:`matching_bomb`: objects listing 64 copies of one value of a ``shuffle``d attribute, and
goals accepting a value no object has. Checked by asking every goal, object and pooled value,
a 13 KB file took 8.8 s and a 60 KB one minutes; the file is valid otherwise (in reach, no
overlaps, as many goals as blocks), so only the matching can refuse it.
"""

from __future__ import annotations

#: Values each object lists (a task file's most).
LISTED = 64


def matching_bomb(size: int) -> str:
    """The largest such file of at most ``size`` characters (at least one object and goal)."""
    count = 1
    while len(_bomb(count + 1)) <= size and count < 256:
        count += 1
    return _bomb(count)


def _bomb(count: int) -> str:
    values = ", ".join(['"r"'] * LISTED)
    parts = ['name = "matching bomb"\nshuffle = ["colour"]\n']
    for i in range(count):  # a grid 5 cm apart: in reach, no overlaps
        x, y = 0.12 + 0.05 * (i % 15), -0.55 + 0.05 * (i // 15)
        parts.append(
            f'[[objects]]\nid = "o{i}"\ncategory = "block"\nposition = [{x:.2f}, {y:.2f}, 0.02]\n'
            f"attributes = {{ colour = [{values}] }}\n"
        )
    for i in range(count):
        x, y = 0.12 + 0.05 * (i % 15), 0.05 + 0.05 * (i // 15)
        parts.append(
            f'[[goals]]\nid = "g{i}"\ncategory = "block"\nposition = [{x:.2f}, {y:.2f}, 0.02]\n'
            'accepts = { colour = "nobody" }\n'
        )
    return "".join(parts)


def reference_file() -> str:
    """A normal file of the same shape: four objects, four goals, every goal fillable."""
    parts = ['name = "reference"\nshuffle = ["colour"]\n']
    colours = ["red", "blue", "red", "blue"]
    for i, colour in enumerate(colours):
        parts.append(
            f'[[objects]]\nid = "o{i}"\ncategory = "block"\n'
            f"position = [{0.3 + 0.1 * i:.2f}, -0.2, 0.02]\n"
            f'attributes = {{ colour = ["{colour}", "green"] }}\n'
        )
    for i, colour in enumerate(colours):
        parts.append(
            f'[[goals]]\nid = "g{i}"\ncategory = "block"\n'
            f"position = [{0.3 + 0.1 * i:.2f}, 0.2, 0.02]\n"
            f'accepts = {{ colour = "{colour}" }}\n'
        )
    return "".join(parts)
