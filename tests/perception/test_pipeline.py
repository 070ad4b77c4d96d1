"""Perception on rendered frames: Scene out, object permanence, filling, stale, bad input."""

from __future__ import annotations

import logging

import cv2
import numpy as np
import pytest

from manigraph_perception.pipelines.aruco.pipeline import Perception, draw_detections
from manigraph_shared.errors import ConfigError
from manigraph_shared.messages import CompressedImage, LayoutObject, Vector3

NOW = 1_700_000_000.0


@pytest.fixture
def perception(markers, calibration) -> Perception:  # type: ignore[no-untyped-def]
    return Perception(markers, calibration)


def test_the_scene_holds_every_object_where_the_sim_has_it(perception, frame) -> None:  # type: ignore[no-untyped-def]
    start = frame("stack4-start")
    perception.set_layout(start.layout)
    scene, detections = perception.process(start.grey, NOW, NOW)
    assert scene is not None and not scene.stale
    assert scene.episode_id == "stack-0" and scene.stamp == NOW
    for obj in scene.objects:
        error = np.linalg.norm(np.array(obj.position.as_tuple()) - start.truth[obj.id])
        assert error < 0.003, (obj.id, error)
        assert obj.visible and not obj.filled
    assert [g.id for g in scene.goals] == [g.id for g in start.layout.goals]
    assert not any(g.filled for g in scene.goals)
    assert {m.object_id for m in detections.markers} == {f"block_{i}" for i in range(4)}


def test_a_placed_block_fills_its_goal(perception, frame) -> None:  # type: ignore[no-untyped-def]
    perception.set_layout(frame("stack4-start").layout)
    perception.process(frame("stack4-start").grey, NOW, NOW)
    scene, _ = perception.process(frame("stack4-one-placed").grey, NOW + 1, NOW + 1)
    assert scene is not None
    assert scene.goal("goal_0").filled and scene.object("block_3").filled
    assert not scene.goal("goal_1").filled and not scene.object("block_2").filled


def test_an_unseen_block_keeps_its_last_pose(perception, frame) -> None:  # type: ignore[no-untyped-def]
    start, placed = frame("stack4-start"), frame("stack4-one-placed")
    perception.set_layout(start.layout)
    first, detections = perception.process(start.grey, NOW, NOW)
    assert first is not None
    # Paint over every marker of block_0 in the second frame: it is hidden now.
    grey = placed.grey.copy()
    for marker in detections.markers:
        if marker.object_id == "block_0":
            corners = np.array(marker.corners).reshape(4, 2)
            cv2.fillConvexPoly(grey, np.round(corners).astype(np.int32), 170)
            x0, y0 = corners.min(axis=0).astype(int) - 3
            x1, y1 = corners.max(axis=0).astype(int) + 3
            grey[y0:y1, x0:x1] = 170
    second, seen = perception.process(grey, NOW + 1, NOW + 1)
    assert second is not None and not second.stale
    assert "block_0" not in {m.object_id for m in seen.markers}
    assert second.object("block_0").position == first.object("block_0").position
    assert second.object("block_0").visible  # hidden by a block, not by a closed box
    assert second.object("block_3").position != first.object("block_3").position


def test_no_marker_keeps_the_last_world_flagged_stale(perception, frame) -> None:  # type: ignore[no-untyped-def]
    perception.set_layout(frame("stack4-start").layout)
    first, _ = perception.process(frame("stack4-start").grey, NOW, NOW)
    second, _ = perception.process(frame("blank").grey, NOW + 1, NOW + 1)
    assert first is not None and second is not None
    assert second.stale and not first.stale
    assert second.objects == first.objects
    assert perception.counters.stale == 1


@pytest.mark.parametrize("partially_observable", [False, True])
def test_a_closed_box_hides_what_it_holds_if_partially_observable(
    perception, frame, partially_observable: bool
) -> None:  # type: ignore[no-untyped-def]
    pack = frame("boxpack3-start")
    layout = pack.layout.replace(partially_observable=partially_observable)
    perception.set_layout(layout)
    scene, _ = perception.process(pack.grey, NOW, NOW)
    assert scene is not None
    assert scene.goal("lid_goal_0").filled and scene.object("cover_0").filled
    inside = [g for g in scene.goals if g.id.startswith("goal_")]
    assert len(inside) == 3
    assert all(g.visible is not partially_observable for g in inside)
    assert all(o.visible for o in scene.objects)  # the blocks stand beside the box


def test_a_corrupt_frame_is_counted_and_skipped(perception, frame) -> None:  # type: ignore[no-untyped-def]
    perception.set_layout(frame("stack4-start").layout)
    bad = CompressedImage(camera="front", stamp=NOW, sequence=4, format="jpeg", data=b"\xff\xd8xx")
    assert perception.process_image(bad, NOW) == (None, None)
    small = cv2.imencode(".png", np.zeros((10, 10), np.uint8))[1].tobytes()
    wrong = CompressedImage(camera="front", stamp=NOW, sequence=5, format="png", data=small)
    assert perception.process_image(wrong, NOW) == (None, None)
    assert perception.counters.corrupt == 2 and "corrupt 2" in perception.counters.summary()
    good = CompressedImage(
        camera="front", stamp=NOW, sequence=6, format="png", data=frame("stack4-start").png
    )
    scene, _ = perception.process_image(good, NOW)
    assert scene is not None and not scene.stale


def test_an_unknown_marker_is_ignored_with_one_warning(perception, frame, markers, caplog) -> None:  # type: ignore[no-untyped-def]
    start = frame("stack4-start")
    perception.set_layout(start.layout)
    dictionary = cv2.aruco.getPredefinedDictionary(cv2.aruco.DICT_4X4_250)
    grey = start.grey.copy()
    grey[380:460, 500:580] = 255
    grey[390:450, 510:570] = cv2.aruco.generateImageMarker(dictionary, 249, 60)
    assert 249 not in markers.by_id()
    with caplog.at_level(logging.WARNING, logger="manigraph.perception"):
        for i in range(3):
            scene, detections = perception.process(grey, NOW + i, NOW + i)
    assert [r.getMessage() for r in caplog.records] == [
        "marker id 249 is not in the marker map: ignored"
    ]
    assert scene is not None and len(scene.objects) == 4
    assert any(m.id == 249 and m.object_id == "" for m in detections.markers)


def test_a_layout_object_without_a_marker_is_refused_by_name(perception, frame) -> None:  # type: ignore[no-untyped-def]
    layout = frame("stack4-start").layout
    extra = LayoutObject(
        id="mug_0",
        category="block",
        size=Vector3(x=0.04, y=0.04, z=0.04),
        position=Vector3(x=0.5, y=0.0, z=0.02),
    )
    bad = layout.replace(objects=[*layout.objects, extra])
    with pytest.raises(ConfigError, match="mug_0"):
        perception.set_layout(bad)


def test_detections_are_drawn(perception, frame) -> None:  # type: ignore[no-untyped-def]
    start = frame("stack4-start")
    _, detections = perception.process(start.grey, NOW, NOW)
    bgr = cv2.cvtColor(start.grey, cv2.COLOR_GRAY2BGR)
    drawn = draw_detections(bgr, detections)
    assert np.count_nonzero(np.any(drawn != bgr, axis=2)) > 100
