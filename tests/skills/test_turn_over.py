"""Which tilts turn a dish over (``families.dishwasher.turn_over``): pure geometry."""

from __future__ import annotations

import numpy as np
import pytest
from arm_helpers import PerfectArm

from manigraph_dishwasher.skills.turn_over import (
    next_tilts,
    quaternion_of,
    set_down_hands,
    top_down_rotation,
    up_index,
)
from manigraph_shared.messages import ObjectCategory, Scene, SceneObject, Vector3
from manigraph_shared.orientations import (
    ORIENTATIONS,
    UPRIGHT,
    UPSIDE_DOWN,
    postures_like,
    up_axis_orientation,
)
from manigraph_shared.rotations import rotation_matrix
from manigraph_skills.drivers.panda_motion import PandaMotionDriver

BOWL = np.array([0.05, 0.05, 0.035])
PLATE = np.array([0.064, 0.064, 0.015])
WIDE_PLATE = np.array([0.08, 0.08, 0.015])


def _tilt(dish: np.ndarray, size: np.ndarray, target: int) -> np.ndarray:
    """The dish after the first tilt ``next_tilts`` offers, set down by the first hand that
    gives one of the up axes it was offered for (as the driver does)."""
    tilts = next_tilts(dish, size, (target,))
    assert tilts
    wanted = list(dict.fromkeys([target, *(t.up_after for t in tilts)]))
    hand = top_down_rotation(tilts[0].pick_yaw)
    side = set_down_hands(hand, dish, wanted)[0]
    return side @ hand.T @ dish


@pytest.mark.parametrize("size", [BOWL, PLATE], ids=["bowl", "plate"])
@pytest.mark.parametrize("start", range(6))
@pytest.mark.parametrize("target", range(6))
def test_every_orientation_is_at_most_two_tilts_away(
    size: np.ndarray, start: int, target: int
) -> None:
    dish = rotation_matrix(ORIENTATIONS[start])
    assert up_index(dish) == start
    for _tilt_number in range(2):
        if up_index(dish) == target:
            break
        dish = _tilt(dish, size, target)
    assert up_index(dish) == target


def test_a_plate_too_wide_for_the_fingers_cannot_be_stood_up_from_flat() -> None:
    flat = rotation_matrix(ORIENTATIONS[0])
    assert next_tilts(flat, WIDE_PLATE, (2,)) == []
    assert next_tilts(flat, PLATE, (2,))


def test_rotations_and_quaternions_round_trip() -> None:
    for q in ORIENTATIONS:
        again = quaternion_of(rotation_matrix(q))
        assert up_axis_orientation(again) == up_axis_orientation(q)
        assert np.allclose(rotation_matrix(again), rotation_matrix(q))


def test_a_plate_on_any_edge_stands_as_upright_asks_and_a_bowl_only_as_asked() -> None:
    assert set(postures_like("plate", UPRIGHT)) == {2, 3, 4, 5}
    assert postures_like("plate", UPRIGHT)[0] == UPRIGHT  # the one asked first
    assert postures_like("plate", 0) == (0,)  # lying flat is not on its rim
    assert postures_like("bowl", UPSIDE_DOWN) == (UPSIDE_DOWN,)


def test_a_flat_plate_is_stood_on_its_rim_with_the_hand_rolled_either_way() -> None:
    """Stood up from flat onto any edge, a plate may be set down by hands rolled both ways
    about their fingers (the wrist above the fingers, or below them, where it met the
    counter); asked for "rim-y" alone, by one roll only."""
    flat = rotation_matrix(ORIENTATIONS[0])
    tilt = next_tilts(flat, PLATE, postures_like("plate", UPRIGHT))[0]
    hand = top_down_rotation(tilt.pick_yaw)
    only_asked = set_down_hands(hand, flat, [UPRIGHT])
    any_edge = set_down_hands(hand, flat, list(postures_like("plate", UPRIGHT)))
    assert len(any_edge) > len(only_asked)
    rolls = {round(float(side[2, 0]), 3) for side in any_edge}  # the hand's x axis, up or down
    assert len(rolls) == 2


def test_a_plate_standing_on_another_edge_is_not_turned_over() -> None:
    arm = PerfectArm()
    driver = PandaMotionDriver(arm)
    side_x = SceneObject(
        id="plate_0",
        category=ObjectCategory.PLATE,
        position=Vector3(x=0.4, y=0.0, z=0.032),
        orientation=ORIENTATIONS[4],
        size=Vector3(x=0.064, y=0.064, z=0.015),
    )
    scene = Scene(episode_id="e", stamp=1.0, sequence=0, objects=[side_x], goals=[])
    assert driver.turn_over("e:1", side_x, ORIENTATIONS[UPRIGHT], scene) is side_x
    assert arm.sent == []  # the arm did not move
