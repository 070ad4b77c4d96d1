"""The soak's oversized requests (``bench/soak.py``): a scene of hundreds of objects and goals
for the explain bomb, and a task file of overlapping blocks padded to a given size."""

from __future__ import annotations

import time

from manigraph_shared.messages import Scene, SceneGoal, SceneObject, Vector3


def big_scene(objects: int, goals: int) -> Scene:
    return Scene(
        episode_id="bomb",
        stamp=time.time(),
        sequence=0,
        objects=[
            SceneObject(
                id=f"block_{i}",
                category="block",
                position=Vector3(x=0.3 + 0.02 * (i % 20), y=-0.3 + 0.05 * (i // 20), z=0.02),
                size=Vector3(x=0.04, y=0.04, z=0.04),
            )
            for i in range(objects)
        ],
        goals=[
            SceneGoal(
                id=f"goal_{i}", category="block", position=Vector3(x=0.5, y=0.2, z=0.02 + 0.04 * i)
            )
            for i in range(goals)
        ],
    )


def overlapping_task_file(size: int) -> str:
    lines = []
    for i in range(256):
        lines += [
            "[[objects]]",
            f'id = "block_{i}"',
            'category = "block"',
            "position = [0.5, 0.0, 0.02]",
            "",
        ]
    lines += ["[[goals]]", 'id = "g"', 'category = "block"', "position = [0.4, 0.2, 0.02]", ""]
    text = "\n".join(lines)
    return (text + "#" * size)[: size - 1] + "\n"
