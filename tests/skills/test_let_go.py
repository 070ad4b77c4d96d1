"""Letting go of a dish set down sideways (the turn-over manoeuvre): the hand backs off along
its fingers, less if a neighbour is behind it, or rises straight away."""

from __future__ import annotations

import numpy as np
import pytest
from arm_helpers import PerfectArm

from manigraph_dishwasher.skills.panda_turn_over import _clear_let_go
from manigraph_shared.errors import SkillError
from manigraph_skills.drivers.panda_motion import PandaMotionDriver
from manigraph_skills.motion import HOME_Q
from manigraph_skills.motion.model import top_down
from manigraph_skills.motion.plan import UP
from manigraph_skills.motion.tilt import BACK_OFFS, let_go_sideways, set_down_sideways
from manigraph_skills.obstacles import Obstacle

#: The hand horizontal, fingers pointing along the counter (+y), closing along x.
SIDEWAYS = np.column_stack([(0.0, 0.0, 1.0), (1.0, 0.0, 0.0), (0.0, 1.0, 0.0)])
TCP = np.array([0.45, 0.0, 0.06])


@pytest.fixture(scope="module")
def driver() -> PandaMotionDriver:
    return PandaMotionDriver(PerfectArm())


@pytest.fixture(scope="module")
def sideways(driver: PandaMotionDriver) -> np.ndarray:
    """The arm holding a dish set down sideways at ``TCP``, as the turn-over sets it down."""
    planner = driver.planner
    held = planner.ik.solve_or_raise(top_down(TCP + 0.1 * UP, np.pi / 2), HOME_Q, "held")
    return set_down_sideways(planner, held, SIDEWAYS, TCP).final


def _hand_after(driver: PandaMotionDriver, way: object) -> np.ndarray:
    return driver.model.tcp_pose(way.positions[-1]).translation  # type: ignore[attr-defined]


def test_the_ways_back_off_less_and_less_then_rise_straight(
    driver: PandaMotionDriver, sideways: np.ndarray
) -> None:
    ways = list(let_go_sideways(driver.planner, sideways))
    assert len(ways) == len(BACK_OFFS)
    backed = [TCP[1] - _hand_after(driver, way)[1] for way in ways]
    assert backed == pytest.approx(list(BACK_OFFS), abs=0.005)
    assert all(_hand_after(driver, way)[2] > TCP[2] + 0.09 for way in ways)


def test_a_neighbour_behind_the_hand_leaves_only_the_straight_rise(
    driver: PandaMotionDriver, sideways: np.ndarray
) -> None:
    # A thin dish behind one end of the hand: every back-off drives the hand into it.
    behind = (Obstacle("neighbour", (0.53, -0.16, 0.025), (0.03, 0.01, 0.05)),)
    assert driver.collision is not None and driver.collision.touching(sideways, behind) == []
    chosen = _clear_let_go(driver, sideways, behind, None)
    assert _hand_after(driver, chosen)[:2] == pytest.approx(TCP[:2], abs=0.005)


def test_a_hand_boxed_in_is_refused_naming_the_neighbour(
    driver: PandaMotionDriver, sideways: np.ndarray
) -> None:
    lid = (Obstacle("lid", (0.45, 0.0, 0.14), (0.3, 0.3, 0.02)),)
    with pytest.raises(SkillError) as refused:
        _clear_let_go(driver, sideways, lid, None)
    assert refused.value.reason == "collision" and "lid" in refused.value.detail
