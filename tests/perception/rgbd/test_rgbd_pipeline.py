"""The RGB-D pipeline on frames drawn analytically (``synthetic.py``: exact geometry, no
renderer): table plane, segmentation, colour, identity over time, filled, bad frames."""

from __future__ import annotations

import numpy as np
import pytest
from synthetic import draw

from manigraph_perception.calibration_file import Calibration
from manigraph_perception.pipeline import BadFrame
from manigraph_perception.pipelines.rgbd.identity import IdentityMode
from manigraph_perception.pipelines.rgbd.pipeline import RgbdPerception
from manigraph_perception.pipelines.rgbd.plane import PlaneConfig, fit_table
from manigraph_perception.pipelines.rgbd.segment import SegmentConfig, hue_peaks
from manigraph_shared.messages import (
    GoalCategory,
    LayoutGoal,
    LayoutObject,
    ObjectCategory,
    TaskLayout,
    Vector3,
)
from manigraph_sim.physics.camera import CameraConfig, ideal_calibration

SIDE = 0.04


@pytest.fixture
def calibration() -> Calibration:
    k, base_T_camera = ideal_calibration(CameraConfig())
    return Calibration(k, base_T_camera=base_T_camera)


def _v(x: float, y: float, z: float) -> Vector3:
    return Vector3(x=x, y=y, z=z)


def _layout(
    starts: dict[str, tuple[float, float, float]],
    goals: dict[str, tuple[float, float, float]] | None = None,
    colours: dict[str, str] | None = None,
) -> TaskLayout:
    return TaskLayout(
        episode_id="synthetic",
        stamp=0.0,
        objects=[
            LayoutObject(
                id=object_id,
                category=ObjectCategory.BLOCK,
                position=_v(*start),
                size=_v(SIDE, SIDE, SIDE),
                attributes={"colour": colours[object_id]} if colours else {},
            )
            for object_id, start in starts.items()
        ],
        goals=[
            LayoutGoal(id=goal_id, category=GoalCategory.BLOCK, position=_v(*where))
            for goal_id, where in (goals or {"goal_0": (0.3, -0.3, 0.02)}).items()
        ],
    )


RED, BLUE, GREEN = (0.5, 0.0, 0.02), (0.5, 0.0, 0.06), (0.4, 0.15, 0.02)
STARTS = {"block_0": RED, "block_1": BLUE, "block_2": GREEN}
COLOURS = {"block_0": "red", "block_1": "blue", "block_2": "green"}


def _scene_positions(perception: RgbdPerception, bgr, depth, stamp: float):  # type: ignore[no-untyped-def]
    scene, result = perception.process(bgr, depth, stamp, stamp)
    assert scene is not None
    return scene, result, {o.id: np.array(o.position.as_tuple()) for o in scene.objects}


def test_a_stack_and_a_block_are_found_posed_and_named(calibration: Calibration) -> None:
    bgr, depth = draw(
        calibration, [(RED, SIDE, "red"), (BLUE, SIDE, "blue"), (GREEN, SIDE, "green")]
    )
    perception = RgbdPerception(calibration, identity=IdentityMode.PRIOR)
    perception.set_layout(_layout(STARTS))
    scene, result, positions = _scene_positions(perception, bgr, depth, 1.0)
    assert not scene.stale
    assert abs(result.plane.offset) < 1e-3 and result.plane.normal[2] > 0.9999
    named = {object_id: d.colour for object_id, d in result.matches.items()}
    assert named == COLOURS
    assert result.matches["block_0"].covered  # the blue block stands on it
    assert not result.matches["block_1"].covered
    for object_id, start in STARTS.items():
        assert np.linalg.norm(positions[object_id] - start) < 0.004, object_id
    top = result.matches["block_2"]
    assert np.allclose(top.size, SIDE, atol=0.006) and abs(top.yaw) < np.deg2rad(3)


def test_identity_follows_a_moved_block_and_hidden_blocks_stay_put(
    calibration: Calibration,
) -> None:
    perception = RgbdPerception(calibration, identity=IdentityMode.PRIOR)
    perception.set_layout(_layout(STARTS))
    bgr, depth = draw(
        calibration, [(RED, SIDE, "red"), (BLUE, SIDE, "blue"), (GREEN, SIDE, "green")]
    )
    _scene_positions(perception, bgr, depth, 1.0)
    # The green block moved 20 cm; the stack is hidden behind the arm (no pixel of it).
    moved = (0.35, -0.1, 0.02)
    bgr, depth = draw(calibration, [(moved, SIDE, "green")])
    _, result, positions = _scene_positions(perception, bgr, depth, 2.0)
    assert set(result.matches) == {"block_2"}
    assert np.linalg.norm(positions["block_2"] - moved) < 0.004
    assert np.linalg.norm(positions["block_0"] - RED) < 0.004  # permanence
    assert np.linalg.norm(positions["block_1"] - BLUE) < 0.004


def test_two_blocks_of_one_colour_keep_their_ids_by_place(calibration: Calibration) -> None:
    a, b = (0.45, -0.1, 0.02), (0.45, 0.1, 0.02)
    perception = RgbdPerception(calibration, identity=IdentityMode.PRIOR)
    perception.set_layout(_layout({"block_0": a, "block_1": b}))
    bgr, depth = draw(calibration, [(a, SIDE, "red"), (b, SIDE, "red")])
    _scene_positions(perception, bgr, depth, 1.0)
    # block_1 moves a little; block_0 stays: each keeps its id.
    b2 = (0.47, 0.12, 0.02)
    bgr, depth = draw(calibration, [(a, SIDE, "red"), (b2, SIDE, "red")])
    _, _, positions = _scene_positions(perception, bgr, depth, 2.0)
    assert np.linalg.norm(positions["block_0"] - a) < 0.004
    assert np.linalg.norm(positions["block_1"] - b2) < 0.004


def test_a_task_colour_rules_out_a_block_of_another_colour(calibration: Calibration) -> None:
    perception = RgbdPerception(calibration, identity=IdentityMode.PRIOR)
    perception.set_layout(_layout({"block_0": RED}, colours={"block_0": "red"}))
    bgr, depth = draw(calibration, [(RED, SIDE, "green")])  # a green block where red should be
    scene, result, _ = _scene_positions(perception, bgr, depth, 1.0)
    assert not result.matches and scene.stale
    assert perception.counters.unmatched == 1


def test_filled_comes_from_the_tracked_block_with_hysteresis(calibration: Calibration) -> None:
    goal = (0.5, 0.1, 0.02)
    perception = RgbdPerception(calibration, identity=IdentityMode.PRIOR)
    perception.set_layout(_layout({"block_0": RED}, goals={"goal_0": goal}))
    bgr, depth = draw(calibration, [(RED, SIDE, "red")])
    scene, _, _ = _scene_positions(perception, bgr, depth, 1.0)
    assert not scene.goals[0].filled
    on_goal = (0.5, 0.115, 0.02)  # 1.5 cm off: fills (within 2.5 cm)
    bgr, depth = draw(calibration, [(on_goal, SIDE, "red")])
    scene, _, _ = _scene_positions(perception, bgr, depth, 2.0)
    assert scene.goals[0].filled
    nudged = (0.5, 0.13, 0.02)  # 3 cm off: stays filled (empties beyond 3.5 cm)
    bgr, depth = draw(calibration, [(nudged, SIDE, "red")])
    scene, _, _ = _scene_positions(perception, bgr, depth, 3.0)
    assert scene.goals[0].filled


def test_a_carried_block_is_put_where_the_robot_let_go_of_it(calibration: Calibration) -> None:
    goal = (0.3, -0.2, 0.02)
    perception = RgbdPerception(calibration, identity=IdentityMode.PRIOR)
    perception.set_layout(_layout({"block_0": RED}, goals={"goal_0": goal}))
    bgr, depth = draw(calibration, [(RED, SIDE, "red")])
    _scene_positions(perception, bgr, depth, 1.0)
    perception.world.on_action("synthetic", "block_0", "goal_0")
    perception.world.on_gripper(0.04)  # closed on the block
    perception.world.on_gripper(0.08)  # let go (the camera did not see it land)
    bgr, depth = draw(calibration, [])
    scene, _, positions = _scene_positions(perception, bgr, depth, 2.0)
    assert np.linalg.norm(positions["block_0"] - goal) < 1e-9
    assert scene.goals[0].filled


def test_depth_of_the_wrong_size_is_refused_by_name(calibration: Calibration) -> None:
    perception = RgbdPerception(calibration, identity=IdentityMode.PRIOR)
    bgr, depth = draw(calibration, [])
    with pytest.raises(BadFrame, match=r"depth 320 x 240 .* calibrated for 640 x 480") as caught:
        perception.process(bgr, depth[::2, ::2], 1.0, 1.0)
    assert caught.value.kind == "wrong_size" and perception.counters.wrong_size == 1


@pytest.mark.parametrize(
    ("depth_value", "reason"),
    [(0.0, "only 0 pixels with depth"), (0.3, "no plane within"), (None, "holds")],
)
def test_a_frame_without_the_table_is_refused_by_name(
    calibration: Calibration, depth_value: float | None, reason: str
) -> None:
    perception = RgbdPerception(calibration, identity=IdentityMode.PRIOR)
    bgr, depth = draw(calibration, [])
    if depth_value is None:
        # Mostly clutter: the table shows in a tenth of the image only.
        depth = np.where(
            np.arange(640)[None, :] < 64, depth, 0.3 + np.random.default_rng(0).random((480, 640))
        )
    else:
        depth[:] = depth_value  # nothing in range, or a wall 30 cm in front of the camera
    with pytest.raises(BadFrame, match=reason) as caught:
        perception.process(bgr, depth, 1.0, 1.0)
    assert caught.value.kind == "no_plane" and perception.counters.no_plane == 1


def test_the_table_plane_is_found_among_outliers() -> None:
    rng = np.random.default_rng(4)
    table = np.column_stack([rng.uniform(0.2, 0.8, (900, 2)), rng.normal(0.003, 0.002, 900)])
    clutter = rng.uniform([0.2, -0.3, 0.0], [0.8, 0.3, 0.3], (300, 3))
    plane = fit_table(np.vstack([table, clutter]), PlaneConfig(), rng)
    assert abs(plane.offset + 0.003) < 0.001 and plane.normal[2] > np.cos(np.deg2rad(0.5))
    level = plane.levelling()
    lifted = table @ level[:3, :3].T + level[:3, 3]
    assert abs(np.median(lifted[:, 2])) < 0.001


def test_one_peak_per_colour_even_for_a_small_share() -> None:
    hues = np.concatenate([np.full(3000, 17), np.full(200, 3), np.full(1000, 104)])
    assert sorted(hue_peaks(hues, SegmentConfig())) == [3.0, 17.0, 104.0]
    wrapped = np.concatenate([np.full(500, 178), np.full(500, 1)])  # red on both ends
    assert len(hue_peaks(wrapped, SegmentConfig())) == 1


def test_the_segmentation_picture_shows_each_segment_beside_the_depth(
    calibration: Calibration,
) -> None:
    from manigraph_perception.pipelines.rgbd.drawing import draw_segmentation

    bgr, depth = draw(calibration, [(RED, SIDE, "red"), (GREEN, SIDE, "green")])
    perception = RgbdPerception(calibration, identity=IdentityMode.PRIOR)
    perception.set_layout(_layout({"block_0": RED, "block_2": GREEN}))
    result = perception.measure(bgr, depth)
    picture = draw_segmentation(bgr, depth, result)
    assert picture.shape == (480, 1280, 3)
    rows, cols = np.nonzero(result.labels == 1)
    # The segment is tinted with its colour's hue, the table around it darkened.
    assert picture[rows, cols].mean() != bgr[rows, cols].mean()
    assert picture[5, 5].sum() < bgr[5, 5].sum()


def test_a_block_first_seen_far_from_its_start_learns_its_colour_and_keeps_it(
    calibration: Calibration,
) -> None:
    red, green, yellow = (0.5, -0.1, 0.02), (0.6, 0.2, 0.02), (0.45, 0.1, 0.02)
    perception = RgbdPerception(calibration, identity=IdentityMode.PRIOR)
    perception.set_layout(_layout({"block_0": red, "block_1": green, "block_2": yellow}))
    bgr, depth = draw(calibration, [(red, SIDE, "red"), (yellow, SIDE, "yellow")])
    _scene_positions(perception, bgr, depth, 1.0)  # green unseen: its hue is not known
    moved = (0.35, -0.05, 0.02)  # green seen 30 cm from its start: no other block is green
    bgr, depth = draw(
        calibration, [(red, SIDE, "red"), (yellow, SIDE, "yellow"), (moved, SIDE, "green")]
    )
    _scene_positions(perception, bgr, depth, 2.0)
    # Yellow moves onto green's place while green is out of sight: yellow is yellow.
    onto = (0.35, -0.05, 0.06)
    bgr, depth = draw(calibration, [(red, SIDE, "red"), (onto, SIDE, "yellow")])
    _, result, positions = _scene_positions(perception, bgr, depth, 3.0)
    assert "block_1" not in result.matches
    assert np.linalg.norm(positions["block_2"] - onto) < 0.004
    assert np.linalg.norm(positions["block_1"] - moved) < 0.004
