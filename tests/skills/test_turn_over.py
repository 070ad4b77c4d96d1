"""Which tilts turn a dish over (``manigraph_skills.turn_over``): pure geometry."""

from __future__ import annotations

import numpy as np
import pytest

from manigraph_shared.orientations import ORIENTATIONS, up_axis_orientation
from manigraph_skills.turn_over import (
    next_tilts,
    quaternion_of,
    rotation_of,
    set_down_hands,
    top_down_rotation,
    up_index,
)

BOWL = np.array([0.05, 0.05, 0.035])
PLATE = np.array([0.064, 0.064, 0.015])
WIDE_PLATE = np.array([0.08, 0.08, 0.015])


def _tilt(dish: np.ndarray, size: np.ndarray, target: int) -> np.ndarray:
    """The dish after the first tilt ``next_tilts`` offers, set down by the first hand that
    gives one of the up axes it was offered for (as the driver does)."""
    tilts = next_tilts(dish, size, target)
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
    dish = rotation_of(ORIENTATIONS[start])
    assert up_index(dish) == start
    for _tilt_number in range(2):
        if up_index(dish) == target:
            break
        dish = _tilt(dish, size, target)
    assert up_index(dish) == target


def test_a_plate_too_wide_for_the_fingers_cannot_be_stood_up_from_flat() -> None:
    flat = rotation_of(ORIENTATIONS[0])
    assert next_tilts(flat, WIDE_PLATE, 2) == []
    assert next_tilts(flat, PLATE, 2)


def test_rotations_and_quaternions_round_trip() -> None:
    for q in ORIENTATIONS:
        again = quaternion_of(rotation_of(q))
        assert up_axis_orientation(again) == up_axis_orientation(q)
        assert np.allclose(rotation_of(again), rotation_of(q))
