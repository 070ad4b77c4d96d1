"""Markers on rendered frames -> object poses, against the sim's ground truth."""

from __future__ import annotations

import numpy as np

from manigraph_perception.detection import ObjectPoser, detect, detector_for


def _errors(frame, markers, calibration) -> dict[str, float]:  # type: ignore[no-untyped-def]
    sizes = {o.id: np.array(o.size.as_tuple()) for o in frame.layout.objects}
    poser = ObjectPoser(markers, calibration, sizes)
    poses = poser.poses(detect(detector_for(markers), frame.grey))
    return {
        p.object_id: float(np.linalg.norm(p.base_T_object[:3, 3] - frame.truth[p.object_id]))
        for p in poses
    }


def test_every_block_of_a_stack_is_posed_within_3_mm(frame, markers, calibration) -> None:  # type: ignore[no-untyped-def]
    errors = _errors(frame("stack4-start"), markers, calibration)
    assert sorted(errors) == ["block_0", "block_1", "block_2", "block_3"]
    assert max(errors.values()) < 0.003, errors


def test_a_cover_is_posed_from_its_markers(frame, markers, calibration) -> None:  # type: ignore[no-untyped-def]
    errors = _errors(frame("boxpack3-start"), markers, calibration)
    assert "cover_0" in errors and errors["cover_0"] < 0.003, errors
    assert all(e < 0.005 for e in errors.values()), errors


def test_a_blank_image_has_no_markers(frame, markers) -> None:  # type: ignore[no-untyped-def]
    assert detect(detector_for(markers), frame("blank").grey) == []
