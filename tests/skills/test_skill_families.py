"""Each task family declares its skill extensions in one place (its package's ``skills``), and
the skill runner reaches them only through the registry."""

from __future__ import annotations

import numpy as np

from manigraph_blocks.skills.obstacles import box_walls
from manigraph_dishwasher.rules import check_dish_move
from manigraph_dishwasher.skills.obstacles import rack_obstacles
from manigraph_dishwasher.skills.panda_turn_over import turn_dish
from manigraph_dishwasher.skills.slot_room import set_down_point
from manigraph_dishwasher.skills.trays import toggle_tray
from manigraph_shared.messages import Action, EpisodeRequest, Scene
from manigraph_sim.geometric.backend import GeometricBackend
from manigraph_skills.family import FAMILIES, family_of, family_taking
from manigraph_skills.obstacles import scene_obstacles
from manigraph_testkit.families import families_with


def first_scene(task: str, **request: int) -> Scene:
    backend = GeometricBackend()
    backend.reset(EpisodeRequest(episode_id="e", task=task, **request), 0.0)
    return backend.scene(1.0)


def action(family_action: str | None) -> Action:
    return Action(
        decision_id="e:0",
        episode_id="e",
        scene_sequence=0,
        object_id="rack_top",
        goal_id="rack_top" if family_action else "top_bowl_00",
        family_action=family_action,
        policy="test",
        stamp=0.0,
    )


def test_each_family_registers_its_extensions() -> None:
    assert list(FAMILIES) == families_with("skills")
    blocks, dishwasher = FAMILIES["blocks"], FAMILIES["dishwasher"]
    assert blocks.fallback and blocks.part("obstacles") is box_walls
    assert blocks.part("set_down_point") is None and blocks.part("turn_over") is None
    assert dishwasher.part("run_action") is toggle_tray
    assert dishwasher.part("check_move") is check_dish_move
    assert dishwasher.part("set_down_point") is set_down_point
    assert dishwasher.part("obstacles") is rack_obstacles
    assert dishwasher.part("turn_over") is turn_dish


def test_the_runner_finds_the_family_by_the_scene_and_the_action() -> None:
    dishes, blocks = first_scene("dishwasher", objects=4), first_scene("box-pack", blocks=3)
    assert family_of(dishes).name == "dishwasher" and family_of(blocks).name == "blocks"
    taking = family_taking(action("toggle"))
    assert taking is not None and taking.name == "dishwasher"
    assert family_taking(action(None)) is None  # a PickAndPlace


def test_every_familys_fixtures_are_obstacles() -> None:
    dishes, boxes = first_scene("dishwasher", objects=4), first_scene("box-pack", blocks=3)
    moving = dishes.objects[0]
    ids = {o.id for o in scene_obstacles(dishes, moving, np.array(moving.position.as_tuple()))}
    assert {"rack_top:floor", "rack_bottom:floor"} <= ids
    block = boxes.objects[0]
    walls = {o.id for o in scene_obstacles(boxes, block, np.array(block.position.as_tuple()))}
    assert any(":wall" in i for i in walls)
