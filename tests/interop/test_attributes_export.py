"""A task's attributes reach the exports: LeRobot's node columns round-trip them, ROS 2's
scene markers draw an object in its named colour and label goals with what they accept."""

from __future__ import annotations

from manigraph_shared.colours import PALETTE
from manigraph_shared.messages import Scene, SceneGoal, SceneObject, Vector3
from manigraph_tools.interop.lerobot_export import scene_nodes
from manigraph_tools.interop.ros2_messages import scene_markers
from manigraph_training.lerobot_source import frame_scene

BLOCK = Vector3(x=0.04, y=0.04, z=0.04)


def _scene() -> Scene:
    return Scene(
        episode_id="colours",
        stamp=12.5,
        sequence=3,
        objects=[
            SceneObject(
                id="block_0",
                category="block",
                position=Vector3(x=0.5, y=0.1, z=0.02),
                size=BLOCK,
                attributes={"colour": "red", "grade": 2.0},
            ),
            SceneObject(
                id="block_1", category="block", position=Vector3(x=0.5, y=-0.1, z=0.02), size=BLOCK
            ),
        ],
        goals=[
            SceneGoal(
                id="red_bin",
                category="block",
                position=Vector3(x=0.4, y=0.2, z=0.02),
                accepts={"colour": "red", "size": [0.04, 0.04, 0.04]},
            )
        ],
    )


def test_lerobot_node_columns_carry_attributes_and_accepts_back() -> None:
    scene = _scene()
    row = scene_nodes(scene, max_nodes=6)
    row["observation.stamp"], row["observation.scene_sequence"] = scene.stamp, scene.sequence
    back = frame_scene(row, scene.episode_id)
    assert back.object("block_0").attributes == {"colour": "red", "grade": 2.0}
    assert back.object("block_1").attributes == {}
    assert back.goal("red_bin").accepts == {"colour": "red", "size": [0.04, 0.04, 0.04]}


def test_a_dataset_row_without_the_attributes_column_reads_as_none() -> None:
    scene = _scene()
    row = scene_nodes(scene, max_nodes=6)
    del row["observation.nodes.attributes"]
    row["observation.stamp"], row["observation.scene_sequence"] = scene.stamp, scene.sequence
    back = frame_scene(row, scene.episode_id)
    assert back.object("block_0").attributes == {} and back.goal("red_bin").accepts == {}


def test_ros2_markers_draw_the_named_colour_and_say_what_a_goal_accepts() -> None:
    markers = scene_markers(_scene()).markers[1:]
    by_id = {m.text.split(" ")[0]: m for m in markers}
    red = by_id["block_0"]
    assert (red.color.r, red.color.g, red.color.b) == PALETTE["red"]
    assert red.text == "block_0 (colour red, grade 2)"
    assert by_id["block_1"].text == "block_1"
    assert by_id["red_bin"].text == "red_bin (accepts colour red, size [0.04, 0.04, 0.04])"
