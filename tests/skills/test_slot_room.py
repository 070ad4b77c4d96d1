"""Where a bowl is set down in its slot: clear of the dishes beside it (issue 33)."""

from __future__ import annotations

import numpy as np
import pytest

from manigraph_dishwasher.skills.slot_room import (
    CLEARANCE,
    MAX_SHIFT,
    half_across,
    set_down_point,
)
from manigraph_dishwasher.skills.turn_over import quaternion_of
from manigraph_shared.messages import (
    GoalCategory,
    ObjectCategory,
    Scene,
    SceneGoal,
    SceneObject,
    Vector3,
)
from manigraph_shared.orientations import ORIENTATIONS, UPSIDE_DOWN
from manigraph_shared.rotations import rotation_matrix

PITCH = 0.055
SLOT_Z = 0.325


def bowl(name: str, y: float, degrees: float = 0.0, x: float = 0.685) -> SceneObject:
    """A 5 cm bowl upside down at ``y`` on the top rack, turned ``degrees`` about the vertical."""
    t = np.radians(degrees)
    about_z = np.array([[np.cos(t), -np.sin(t), 0.0], [np.sin(t), np.cos(t), 0.0], [0, 0, 1]])
    return SceneObject(
        id=name,
        category=ObjectCategory.BOWL,
        position=Vector3(x=x, y=y, z=SLOT_Z - 0.0025),
        orientation=quaternion_of(about_z @ rotation_matrix(ORIENTATIONS[UPSIDE_DOWN])),
        size=Vector3(x=0.05, y=0.05, z=0.035),
    )


SLOT = SceneGoal(
    id="top_bowl_06",
    category=GoalCategory.BOWL,
    position=Vector3(x=0.685, y=0.0, z=SLOT_Z),
    orientation=ORIENTATIONS[UPSIDE_DOWN],
    fixture="rack_top",
)


def where(*neighbours: SceneObject) -> float:
    moving = bowl("moving", 0.0, x=0.4)  # on the counter
    scene = Scene(
        episode_id="e", stamp=1.0, sequence=0, objects=[moving, *neighbours], goals=[SLOT]
    )
    point = set_down_point(scene, moving, SLOT)
    assert (point.x, point.z) == (SLOT.position.x, SLOT.position.z)
    return point.y


def test_between_square_neighbours_a_bowl_goes_to_its_slots_centre() -> None:
    assert where() == 0.0
    assert where(bowl("left", -PITCH), bowl("right", PITCH)) == 0.0


def test_a_turned_neighbour_moves_the_bowl_as_little_as_leaves_it_room() -> None:
    left = bowl("left", -PITCH, degrees=13.0)  # as a turn-over left it (seed 15012)
    reach = half_across(left, 1)
    assert reach + 0.025 + CLEARANCE > PITCH  # at the centre: no room to spare beside it
    y = where(left, bowl("right", PITCH))
    assert y == pytest.approx(-PITCH + reach + CLEARANCE + 0.025)
    assert 0.0 < y <= MAX_SHIFT
    assert where(bowl("left", -PITCH), bowl("right", PITCH, degrees=-13.0)) == pytest.approx(-y)


def test_between_two_turned_neighbours_it_goes_in_the_middle_and_never_far() -> None:
    assert where(bowl("left", -PITCH, 20.0), bowl("right", PITCH, 20.0)) == pytest.approx(0.0)
    assert where(bowl("left", -0.04, 30.0)) == pytest.approx(MAX_SHIFT)


def test_dishes_in_other_rows_or_racks_and_plates_are_left_alone() -> None:
    assert where(bowl("other_row", -PITCH / 2, 30.0, x=0.615)) == 0.0
    lower = bowl("lower_rack", -PITCH / 2, 30.0)
    lower = lower.replace(position=Vector3(x=0.685, y=-PITCH / 2, z=0.16))
    assert where(lower) == 0.0
    plate = bowl("plate", 0.0, x=0.4).replace(category=ObjectCategory.PLATE)
    scene = Scene(
        episode_id="e", stamp=1.0, sequence=0, objects=[plate, bowl("l", -0.04, 30)], goals=[SLOT]
    )
    assert set_down_point(scene, plate, SLOT) == SLOT.position
