"""How PickAndPlace holds an object: the closing axis with room, a cover by its handle."""

from __future__ import annotations

import numpy as np

from manigraph_shared.grasp_points import COVER_HANDLE_SIZE
from manigraph_shared.messages import (
    GoalCategory,
    ObjectCategory,
    Scene,
    SceneGoal,
    SceneObject,
    Vector3,
)
from manigraph_skills.grasp_choice import TURN_TO_Y, choose_grasps

BLOCK = Vector3(x=0.04, y=0.04, z=0.04)
COVER = Vector3(x=0.27, y=0.27, z=0.01)


def _block(name: str, x: float, y: float, z: float = 0.02) -> SceneObject:
    return SceneObject(
        id=name, category=ObjectCategory.BLOCK, position=Vector3(x=x, y=y, z=z), size=BLOCK
    )


def _scene(*objects: SceneObject) -> Scene:
    goal = SceneGoal(
        id="goal_0", category=GoalCategory.BLOCK, position=Vector3(x=0.4, y=0.3, z=0.02)
    )
    return Scene(episode_id="e", stamp=0.0, sequence=0, objects=list(objects), goals=[goal])


def test_fingers_close_along_x_unless_a_neighbour_is_in_the_way_there() -> None:
    alone = _scene(_block("a", 0.5, 0.0), _block("under_goal", 0.4, 0.3, -0.02))
    pick, place = choose_grasps(alone, alone.object("a"), alone.goals[0].position)
    assert pick.turn == place.turn == 0.0 and pick.height == 0.0 and pick.carry_z == 0.0
    # A neighbour 1 cm away along x: close along y, where the next block is 5.5 cm away.
    boxed = _scene(_block("a", 0.5, 0.0), _block("w", 0.45, 0.0), _block("s", 0.5, -0.095))
    pick, _ = choose_grasps(boxed, boxed.object("a"), boxed.goals[0].position)
    assert pick.turn == TURN_TO_Y
    # Pyramid rows run along y with 4 mm gaps: x stays free, the default holds.
    row = _scene(_block("a", 0.5, 0.0), _block("b", 0.5, 0.044), _block("c", 0.5, -0.044))
    assert choose_grasps(row, row.object("a"), row.goals[0].position)[0].turn == 0.0


def test_a_cover_is_grasped_at_its_handle_and_carried_over_everything() -> None:
    cover = SceneObject(
        id="cover_0",
        category=ObjectCategory.COVER,
        position=Vector3(x=0.5, y=0.0, z=0.055),
        size=COVER,
    )
    scene = _scene(cover, _block("top", 0.4, -0.3, 0.14))  # a 4-block stack's top block
    pick, place = choose_grasps(scene, cover, scene.goals[0].position)
    assert np.isclose(pick.height, 0.005 + COVER_HANDLE_SIZE[2] / 2)
    assert pick.height == place.height
    underside = pick.carry_z - pick.height - COVER.z / 2
    assert underside >= 0.16 + 0.01  # above the stack's top, with room to spare
