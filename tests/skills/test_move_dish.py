"""Moving a dish to a free counter cell to turn it over there (``panda_turn_over``): when it
cannot be taken or set down turned where it lies (a neighbour, a pulled-out rack's floor)."""

from __future__ import annotations

import numpy as np
import pytest
from arm_helpers import PerfectArm, trajectory_of

from manigraph_dishwasher.fixtures import Rack
from manigraph_dishwasher.skills.panda_turn_over import (
    SPARE_Y,
    SPOT_FREE,
    free_cells,
    move_dish,
    set_down_spots,
)
from manigraph_dishwasher.skills.turn_over import up_index
from manigraph_shared.messages import ObjectCategory, Scene, SceneObject, Vector3
from manigraph_shared.orientations import ORIENTATIONS
from manigraph_shared.rotations import rotation_matrix
from manigraph_skills.drivers.panda_motion import PandaMotionDriver

#: A bowl (5 cm across, 3.5 cm deep) lying upside down.
SIZE = Vector3(x=0.05, y=0.05, z=0.035)


def bowl(name: str, x: float, y: float) -> SceneObject:
    return SceneObject(
        id=name,
        category=ObjectCategory.BOWL,
        position=Vector3(x=x, y=y, z=0.0175),
        orientation=ORIENTATIONS[1],
        size=SIZE,
    )


#: bowl_0 on the far row (x = 0.46 m, under a pulled-out rack's front), neighbours on its
#: row and diagonally nearer the robot.
FAR = bowl("bowl_0", 0.46, 0.0)
NEIGHBOURS = [bowl("bowl_1", 0.46, 0.1), bowl("bowl_2", 0.46, -0.1), bowl("bowl_3", 0.38, 0.1)]
SCENE = Scene(episode_id="e", stamp=1.0, sequence=0, objects=[FAR, *NEIGHBOURS], goals=[])


def test_free_cells_are_free_counter_cells_nearest_the_robot_first() -> None:
    cells = free_cells(SCENE, FAR, np.array(FAR.position.as_tuple()))
    assert cells, "the cell in front of the bowl is free"
    assert cells[0] == pytest.approx([0.38, 0.0])
    assert [c[0] for c in cells] == sorted(c[0] for c in cells)
    for cell in cells:
        assert abs(cell[1]) < SPARE_Y  # on the counter, not a spare spot beside it
        assert cell[0] <= FAR.position.x  # never farther out, under the rack
        for other in NEIGHBOURS:
            assert np.linalg.norm(cell - np.array(other.position.as_tuple()[:2])) >= SPOT_FREE


def test_a_dish_on_the_near_row_is_never_moved_off_the_counter_towards_the_base() -> None:
    """Cells nearest the robot come first, and beside the counter (y = 0.3 m) a cell 5 cm
    from the base's x still passed the reach radius: a bowl moved twice on its near row lay
    at x = 0.05 m, outside the workspace, refused by every later pick (seed 2008)."""
    near = bowl("bowl_0", 0.30, -0.30)
    beside = [bowl("bowl_1", 0.38, -0.30), bowl("bowl_2", 0.30, -0.20)]
    scene = Scene(episode_id="e", stamp=1.0, sequence=0, objects=[near, *beside], goals=[])
    cells = free_cells(scene, near, np.array(near.position.as_tuple()))
    assert cells, "the cells diagonally beside it on the counter are free"
    assert all(cell[0] >= 0.29 for cell in cells)


def test_the_dish_is_carried_top_down_and_set_down_on_the_first_cell() -> None:
    arm = PerfectArm()
    driver = PandaMotionDriver(arm)
    here = np.array(FAR.position.as_tuple())
    dish = rotation_matrix(FAR.orientation)
    cells = free_cells(SCENE, FAR, here)
    position, turned = move_dish(driver, "e:1", FAR, SCENE, here, dish, cells)
    assert position == pytest.approx([*cells[0], here[2]])
    assert up_index(turned) == up_index(dish)  # turned about the vertical only
    # Pick, carry, release: the hand ends above the cell, open.
    assert len(arm.sent) == 3 and arm.sent[-1].points[-1].gripper.value == "open"
    carried = trajectory_of(arm.sent[1])
    tcp = driver.model.tcp_pose(carried.final).translation
    assert tcp[:2] == pytest.approx(cells[0], abs=0.002)
    # The rotation returned is the dish turned as far as the hand turned on the way.
    hand_turn = driver.planner.yaw_of(carried.final) - driver.planner.yaw_of(
        trajectory_of(arm.sent[0]).final
    )
    c, s = np.cos(hand_turn), np.sin(hand_turn)
    assert turned == pytest.approx(np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]]) @ dish)


@pytest.mark.parametrize("out", [None, "rack_top", "rack_bottom"])
@pytest.mark.parametrize("dish_y", [-0.3, 0.3])
def test_the_spare_spots_on_a_side_are_offered_only_while_the_rack_whose_handle_is_there_is_in(
    out: str | None, dish_y: float
) -> None:
    """A dish turned over on the left spare spot (0.36, -0.42) lay under the pulled-out
    bottom rack's handle and was refused on every re-plan while that rack was out; the top
    rack's handle is on the right, over the right spots when it is out. With both racks in,
    a dish is turned on its own side (the far side asked a transfer the arm could not make
    without flipping)."""
    dish = bowl("bowl_0", 0.38, dish_y)
    racks = [
        Rack(id=rack, position=Vector3(x=0.6, y=0.0, z=z), open=rack == out).fixture()
        for rack, z in (("rack_top", 0.3), ("rack_bottom", 0.1))
    ]
    scene = SCENE.replace(objects=[dish], fixtures=racks)
    spots = set_down_spots(scene, dish, np.array([0.38, dish_y, 0.0175]))
    beside = [spot for spot in spots if abs(spot[1]) >= SPARE_Y]
    assert beside
    if out == "rack_bottom":
        assert all(spot[1] > 0 for spot in beside)  # its handle is on the left
    elif out == "rack_top":
        assert all(spot[1] < 0 for spot in beside)  # its handle is on the right
    else:
        assert np.sign(beside[0][1]) == np.sign(dish_y)


def test_a_dish_lying_in_a_rack_is_offered_free_counter_cells_nearest_the_robot() -> None:
    """A bowl a placement left in a rack, in no slot: its neighbouring cells are in the rack,
    so the cells offered are the counter's free ones, the near row first, nearest it along y."""
    in_rack = SceneObject(
        id="bowl_4",
        category=ObjectCategory.BOWL,
        position=Vector3(x=0.62, y=0.1, z=0.33),
        orientation=ORIENTATIONS[4],
        size=SIZE,
    )
    crowded = [*NEIGHBOURS, bowl("bowl_5", 0.30, 0.1)]
    scene = Scene(episode_id="e", stamp=1.0, sequence=0, objects=[in_rack, *crowded], goals=[])
    cells = free_cells(scene, in_rack, np.array(in_rack.position.as_tuple()))
    assert cells
    assert all(0.29 <= cell[0] <= 0.46 and abs(cell[1]) <= 0.3 for cell in cells)
    assert cells[0] == pytest.approx([0.30, 0.0])  # (0.30, 0.1) is taken
    for cell in cells:
        for other in crowded:
            assert np.linalg.norm(cell - np.array(other.position.as_tuple()[:2])) >= SPOT_FREE
