"""Objects found without their starting positions (``--identity appearance``): identity by
colour and size at first sight, then by place. Synthetic detections for the tracker, frames
drawn analytically (``synthetic.py``, no renderer) for the pipeline."""

from __future__ import annotations

import itertools
import math
from pathlib import Path

import numpy as np
import pytest
from synthetic import draw

from manigraph_perception.calibration_file import Calibration
from manigraph_perception.layout_file import load_layout
from manigraph_perception.pipelines.rgbd.identity import (
    FORBIDDEN,
    IdentityMode,
    min_cost_assignment,
    strip_positions,
)
from manigraph_perception.pipelines.rgbd.objects import DetectedObject, palette_hues
from manigraph_perception.pipelines.rgbd.pipeline import RgbdPerception
from manigraph_perception.pipelines.rgbd.tracker import Tracker
from manigraph_shared.errors import ConfigError
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
HUES = palette_hues(["red", "green", "blue", "yellow"])
EXAMPLES = Path(__file__).resolve().parents[3] / "examples"


@pytest.fixture
def calibration() -> Calibration:
    k, base_T_camera = ideal_calibration(CameraConfig())
    return Calibration(k, base_T_camera=base_T_camera)


def _v(xyz: tuple[float, float, float]) -> Vector3:
    return Vector3(x=xyz[0], y=xyz[1], z=xyz[2])


def _layout(
    objects: dict[str, tuple[tuple[float, float, float], str | None, float]],
) -> TaskLayout:
    """objects: id -> (start, colour or None, side)."""
    return TaskLayout(
        episode_id="identity",
        stamp=0.0,
        objects=[
            LayoutObject(
                id=object_id,
                category=ObjectCategory.BLOCK,
                position=_v(start),
                size=_v((side, side, side)),
                attributes={"colour": colour} if colour else {},
            )
            for object_id, (start, colour, side) in objects.items()
        ],
        goals=[
            LayoutGoal(id="goal_0", category=GoalCategory.BLOCK, position=_v((0.3, -0.3, 0.02)))
        ],
    )


def _detection(
    xy: tuple[float, float], colour: str, side: float = SIDE, covered: bool = False
) -> DetectedObject:
    return DetectedObject(
        centre=np.array([xy[0], xy[1], side]),
        yaw=0.0,
        size=np.array([side, side, side]),
        hue=HUES[colour],
        colour=colour,
        covered=covered,
        pixels=400,
        bottom=0.0,
        away=np.array([1.0, 0.0]),
        extent_away=side,
    )


# --- the assignment -------------------------------------------------------------------------
@pytest.mark.parametrize("shape", [(4, 4), (3, 6), (6, 3), (1, 5)])
def test_the_assignment_is_the_cheapest_of_all(shape: tuple[int, int]) -> None:
    rng = np.random.default_rng(sum(shape))
    for _ in range(20):
        cost = rng.random(shape)
        pairs = min_cost_assignment(cost)
        assert len(pairs) == min(shape)
        assert len({r for r, _ in pairs}) == len({c for _, c in pairs}) == len(pairs)
        rows, cols = shape
        if rows <= cols:
            best = min(
                sum(cost[r, c] for r, c in enumerate(perm))
                for perm in itertools.permutations(range(cols), rows)
            )
        else:
            best = min(
                sum(cost[r, c] for c, r in enumerate(perm))
                for perm in itertools.permutations(range(rows), cols)
            )
        assert math.isclose(sum(cost[r, c] for r, c in pairs), best)


def test_a_forbidden_pair_is_never_made_even_when_it_is_all_that_is_left() -> None:
    cost = np.array([[1.0, FORBIDDEN], [FORBIDDEN, FORBIDDEN]])
    assert min_cost_assignment(cost) == [(0, 0)]
    assert min_cost_assignment(np.zeros((0, 3))) == []


def test_the_starting_positions_are_stripped_and_the_goals_kept() -> None:
    layout = _layout({"block_0": ((0.5, 0.0, 0.02), "red", SIDE)})
    stripped = strip_positions(layout)
    assert all(math.isnan(v) for v in stripped.objects[0].position.as_tuple())
    assert stripped.goals == layout.goals
    assert stripped.objects[0].attributes == {"colour": "red"}


# --- the tracker, synthetic detections ------------------------------------------------------
def test_objects_are_named_by_colour_wherever_they_stand() -> None:
    layout = strip_positions(
        _layout({f"block_{c}": ((0.0, 0.0, 0.0), c, SIDE) for c in ("red", "green", "blue")})
    )
    tracker = Tracker(layout)
    detections = [
        _detection((0.3, 0.25), "blue"),
        _detection((0.62, -0.3), "red"),
        _detection((0.41, 0.0), "green"),
    ]
    pairs = dict(tracker.acquire(detections, ["block_red", "block_green", "block_blue"]))
    assert {object_id: d.colour for object_id, d in pairs.items()} == {
        "block_red": "red",
        "block_green": "green",
        "block_blue": "blue",
    }


def test_size_tells_apart_objects_of_one_colour_and_a_stranger_is_left_out() -> None:
    layout = strip_positions(
        _layout(
            {
                "small": ((0.0, 0.0, 0.0), "red", 0.03),
                "large": ((0.0, 0.0, 0.0), "red", 0.05),
            }
        )
    )
    tracker = Tracker(layout)
    detections = [
        _detection((0.4, 0.1), "red", 0.05),
        _detection((0.5, 0.0), "yellow", 0.03),  # no yellow object in the layout
        _detection((0.45, -0.2), "red", 0.03),
    ]
    pairs = dict(tracker.acquire(detections, ["small", "large"]))
    assert pairs["small"] is detections[2] and pairs["large"] is detections[0]


def test_identical_objects_take_one_detection_each_and_learn_its_hue() -> None:
    layout = strip_positions(
        _layout({f"block_{i}": ((0.0, 0.0, 0.0), None, SIDE) for i in range(3)})
    )
    tracker = Tracker(layout)
    detections = [
        _detection((0.4, y), c) for y, c in ((-0.1, "red"), (0.0, "green"), (0.1, "blue"))
    ]
    pairs = tracker.acquire(detections, ["block_0", "block_1", "block_2"])
    assert sorted(id(d) for _, d in pairs) == sorted(id(d) for d in detections)
    assert {tracker.hues[o] for o, _ in pairs} == {HUES[c] for c in ("red", "green", "blue")}


# --- the pipeline, analytic frames -----------------------------------------------------------
RED, BLUE, GREEN, YELLOW = (
    (0.5, 0.0, 0.02),
    (0.5, 0.0, 0.06),
    (0.4, 0.15, 0.02),
    (0.42, -0.15, 0.02),
)
TRUTH = {"block_0": (RED, "red"), "block_1": (BLUE, "blue"), "block_2": (GREEN, "green")}


def _process(perception: RgbdPerception, boxes, stamp: float):
    bgr, depth = draw(perception.calibration, boxes)
    scene, result = perception.process(bgr, depth, stamp, stamp)
    positions = (
        {} if scene is None else {o.id: np.array(o.position.as_tuple()) for o in scene.objects}
    )
    return scene, result, positions


@pytest.mark.parametrize("where", ["off by 10 cm", "absent"])
def test_objects_are_found_where_they_stand_not_where_the_layout_says(
    calibration: Calibration, where: str
) -> None:
    rng = np.random.default_rng(7)
    starts = {}
    for object_id, (true, _) in TRUTH.items():
        if where == "absent":
            starts[object_id] = (0.0, 0.0, 0.0)
        else:
            angle = rng.uniform(0, 2 * np.pi)
            starts[object_id] = (
                true[0] + 0.1 * np.cos(angle),
                true[1] + 0.1 * np.sin(angle),
                true[2],
            )
    layout = _layout({o: (starts[o], colour, SIDE) for o, (_, colour) in TRUTH.items()})
    perception = RgbdPerception(calibration)  # appearance: the default
    perception.set_layout(layout)
    scene, result, positions = _process(
        perception, [(RED, SIDE, "red"), (BLUE, SIDE, "blue"), (GREEN, SIDE, "green")], 1.0
    )
    assert scene is not None and not scene.stale
    for object_id, (true, colour) in TRUTH.items():
        assert result.matches[object_id].colour == colour
        # The red block stands under the blue one: found by its sides, within a centimetre.
        reach = 0.012 if object_id == "block_0" else 0.004
        assert np.linalg.norm(positions[object_id] - true) < reach, object_id


def test_the_prior_identity_keeps_the_old_behaviour(calibration: Calibration) -> None:
    """Two red blocks: named by where the layout starts them (prior), whatever that is."""
    a, b = (0.45, -0.1, 0.02), (0.45, 0.1, 0.02)
    layout = _layout({"block_0": (b, "red", SIDE), "block_1": (a, "red", SIDE)})
    perception = RgbdPerception(calibration, identity=IdentityMode.PRIOR)
    perception.set_layout(layout)
    assert perception.missing == []
    _, _, positions = _process(perception, [(a, SIDE, "red"), (b, SIDE, "red")], 1.0)
    assert np.linalg.norm(positions["block_0"] - b) < 0.004
    assert np.linalg.norm(positions["block_1"] - a) < 0.004


def test_no_scene_until_every_object_is_found_and_the_missing_are_named(
    calibration: Calibration,
) -> None:
    perception = RgbdPerception(calibration)
    perception.set_layout(_layout({o: (RED, c, SIDE) for o, (_, c) in TRUTH.items()}))
    assert perception.missing == ["block_0", "block_1", "block_2"]
    scene, result, _ = _process(perception, [(GREEN, SIDE, "green")], 1.0)
    assert scene is None and set(result.matches) == {"block_2"}
    assert perception.missing == ["block_0", "block_1"]
    scene, _, positions = _process(perception, [(RED, SIDE, "red"), (YELLOW, SIDE, "blue")], 2.0)
    assert scene is not None and perception.missing == []
    assert np.linalg.norm(positions["block_2"] - GREEN) < 0.004  # kept from the first frame
    assert np.linalg.norm(positions["block_1"] - YELLOW) < 0.004


def test_identical_blocks_keep_one_consistent_identity_each(calibration: Calibration) -> None:
    a, b = (0.45, -0.1, 0.02), (0.45, 0.1, 0.02)
    # Both start (the layout says) where the other really is: no matter.
    perception = RgbdPerception(calibration)
    perception.set_layout(_layout({"block_0": (b, "red", SIDE), "block_1": (a, "red", SIDE)}))
    _, _, positions = _process(perception, [(a, SIDE, "red"), (b, SIDE, "red")], 1.0)
    first = {o: positions[o] for o in ("block_0", "block_1")}
    assert {tuple(np.round(p[:2], 2)) for p in first.values()} == {a[:2], b[:2]}
    at_b = min(first, key=lambda o: float(np.linalg.norm(first[o] - b)))
    # The one at b moves a little; the other stays: each keeps the id it was given.
    b2 = (0.47, 0.12, 0.02)
    _, _, positions = _process(perception, [(a, SIDE, "red"), (b2, SIDE, "red")], 2.0)
    other = next(o for o in first if o != at_b)
    assert np.linalg.norm(positions[at_b] - b2) < 0.004
    assert np.linalg.norm(positions[other] - a) < 0.004


def test_a_block_stacked_on_and_then_hidden_is_kept(calibration: Calibration) -> None:
    perception = RgbdPerception(calibration)
    perception.set_layout(
        _layout(
            {"block_0": ((0.0, 0.0, 0.0), "red", SIDE), "block_2": ((0.0, 0.0, 0.0), "green", SIDE)}
        )
    )
    _process(perception, [(RED, SIDE, "red"), (GREEN, SIDE, "green")], 1.0)
    # Green is put on red: red is covered (its sides show), its place kept.
    on_red = (RED[0], RED[1], 0.06)
    scene, result, positions = _process(
        perception, [(RED, SIDE, "red"), (on_red, SIDE, "green")], 2.0
    )
    assert scene is not None and result.matches["block_0"].covered
    assert np.linalg.norm(positions["block_0"] - RED) < 0.004
    assert np.linalg.norm(positions["block_2"] - on_red) < 0.004
    # The arm hides the stack entirely: both stay believed where they were.
    scene, result, positions = _process(perception, [], 3.0)
    assert scene is not None and not result.matches
    assert np.linalg.norm(positions["block_0"] - RED) < 0.004
    assert np.linalg.norm(positions["block_2"] - on_red) < 0.004


# --- what a lab writes -----------------------------------------------------------------------
def test_a_task_file_without_single_positions_is_a_layout_for_appearance() -> None:
    layout = load_layout(EXAMPLES / "tasks" / "colour-sort.toml", positions=False)
    assert len(layout.objects) == 4 and all(o.attributes.get("colour") for o in layout.objects)


def test_prior_identity_needs_each_object_s_position(tmp_path: Path) -> None:
    path = tmp_path / "layout.toml"
    path.write_text(
        '[[objects]]\nid = "block_0"\ncategory = "block"\n\n'
        '[[goals]]\nid = "goal_0"\ncategory = "block"\nposition = [0.4, 0.1, 0.02]\n'
    )
    assert load_layout(path, positions=False).objects[0].id == "block_0"
    with pytest.raises(ConfigError, match="position"):
        load_layout(path)
