"""Calibration against the rendered camera's ground truth: intrinsics from synthetic ChArUco
views taken with its camera matrix, extrinsics from the rendered frames' markers."""

from __future__ import annotations

import json
from pathlib import Path

import cv2
import numpy as np
import pytest

from manigraph_perception.calibration_file import Calibration, load_calibration
from manigraph_perception.calibration_fit import (
    CharucoSpec,
    KnownMarker,
    calibrate_intrinsics,
    fit_camera_pose,
    fit_transform,
    observe_markers,
    residuals_mm,
)
from manigraph_shared.cli import main
from manigraph_shared.errors import ConfigError
from manigraph_shared.markers import marker_in_object
from manigraph_shared.rotations import rotation_matrix

FRAMES = ["stack4-start", "stack4-one-placed", "boxpack3-start"]


def _board_view(spec: CharucoSpec, k: np.ndarray, rvec: np.ndarray, tvec: np.ndarray):  # type: ignore[no-untyped-def]
    """The board as the camera (K, pose) sees it: a plane warped by its homography."""
    pixels_per_metre = 2000
    width = spec.squares_x * spec.square
    height = spec.squares_y * spec.square
    board = spec.board().generateImage(
        (int(width * pixels_per_metre), int(height * pixels_per_metre))
    )
    rotation = cv2.Rodrigues(rvec)[0]
    # board pixel (u, v) -> board point (u / ppm, v / ppm, 0) (y down the image, as OpenCV's
    # ChArUco object points have it) -> camera.
    plane = np.column_stack([rotation[:, 0], rotation[:, 1], tvec])
    homography = k @ plane @ np.diag([1 / pixels_per_metre, 1 / pixels_per_metre, 1])
    view = cv2.warpPerspective(board, homography, (640, 480), borderValue=200)
    return cv2.GaussianBlur(view, (3, 3), 0.6)


def test_intrinsics_recover_the_rendered_camera_matrix(calibration: Calibration) -> None:
    spec = CharucoSpec()
    k = calibration.camera_matrix
    rng = np.random.default_rng(0)
    views = []
    for _ in range(12):
        rvec = rng.uniform(-0.5, 0.5, 3)
        tvec = np.array([-0.14, -0.1, 0.5]) + rng.uniform(-0.08, 0.08, 3)
        views.append(_board_view(spec, k, rvec, tvec))
    found, rms = calibrate_intrinsics(views, spec)
    assert rms < 0.5
    assert np.allclose(found.camera_matrix, k, rtol=0.01, atol=3.0), found.camera_matrix
    assert np.all(np.abs(found.distortion[:2]) < 0.05)


def test_intrinsics_need_four_views_of_the_board() -> None:
    with pytest.raises(ConfigError, match="at least 4"):
        calibrate_intrinsics([np.full((480, 640), 128, np.uint8)] * 5, CharucoSpec())


def _known_markers(frame, markers, flat_only: bool = False) -> list[KnownMarker]:  # type: ignore[no-untyped-def]
    """Every marker (or every face-up one) of every body of ``frame`` with its true centre
    (robot frame) and yaw."""
    known = []
    record = json.loads((Path(__file__).parent / "frames" / f"{frame}.json").read_text())
    sizes = {o["id"]: np.array(list(o["size"].values())) for o in record["layout"]["objects"]}
    for body, (position, quaternion) in record["truth"].items():
        rotation = rotation_matrix(quaternion)
        yaw = float(np.arctan2(rotation[1, 0], rotation[0, 0]))
        for spec in markers.for_object(body):
            if flat_only and spec.face != "top":
                continue
            centre = rotation @ marker_in_object(spec, sizes[body])[:3, 3] + np.array(position)
            known.append(KnownMarker(spec.id, spec.size, centre, yaw))
    return known


@pytest.mark.parametrize("affine", [False, True])
def test_extrinsics_recover_the_rendered_camera_pose(
    frame, markers, calibration: Calibration, affine: bool
) -> None:  # type: ignore[no-untyped-def]
    intrinsics = Calibration(calibration.camera_matrix)
    camera_points, base_points = [], []
    for name in FRAMES:
        seen, base = observe_markers(
            [frame(name).grey], intrinsics, markers.dictionary, _known_markers(name, markers)
        )
        camera_points.append(seen)
        base_points.append(base)
    camera, base = np.concatenate(camera_points), np.concatenate(base_points)
    assert len(camera) >= 20
    transform = fit_transform(camera, base, affine=affine)
    residuals = residuals_mm(transform, camera, base)
    assert np.median(residuals) <= 3.0, residuals
    truth = calibration.base_T_camera
    assert truth is not None
    # Over the workspace the fit maps camera points where the true pose does.
    grid = np.stack(
        np.meshgrid(np.linspace(0.3, 0.7, 5), np.linspace(-0.3, 0.3, 5), [0.0, 0.1]), -1
    ).reshape(-1, 3)
    in_camera = (grid - truth[:3, 3]) @ truth[:3, :3]
    mapped = in_camera @ transform[:3, :3].T + transform[:3, 3]
    error_mm = np.linalg.norm(mapped - grid, axis=1) * 1000
    if affine:
        # 12 parameters from markers on three small clusters: fine where the markers were,
        # poor far from them (the affine fit needs markers spread over the workspace).
        assert np.min(error_mm) < 3.0
    else:
        # Extrapolated from three clusters of markers: a few mm off at the far corners.
        assert np.median(error_mm) < 4.0 and error_mm.max() < 8.0, error_mm


def test_extrinsics_command_writes_a_calibration_perception_reads(
    tmp_path: Path, markers, calibration: Calibration, capsys
) -> None:  # type: ignore[no-untyped-def]
    Calibration(calibration.camera_matrix).save(tmp_path / "camera.yaml")
    points = ['dictionary = "DICT_4X4_250"']
    images = []
    for name in FRAMES:
        images.append(str(Path(__file__).parent / "frames" / f"{name}.png"))
    for marker in _known_markers("boxpack3-start", markers, flat_only=True):
        points += [
            "[[markers]]",
            f"id = {marker.id}",
            f"size = {marker.size}",
            f"position = {marker.position.tolist()}",
            f"yaw = {np.rad2deg(marker.yaw)}",
        ]
    (tmp_path / "points.toml").write_text("\n".join(points))
    code = main(
        [
            "calibrate",
            "extrinsics",
            images[2],
            "--intrinsics",
            str(tmp_path / "camera.yaml"),
            "--points",
            str(tmp_path / "points.toml"),
        ]
    )
    assert code == 0
    report = json.loads(capsys.readouterr().out.strip().splitlines()[-1])
    assert report["points"] >= 16 and report["residual_mm_median"] <= 1.0
    written = load_calibration(tmp_path / "camera.yaml")
    assert written.base_T_camera is not None
    truth = calibration.base_T_camera
    assert truth is not None
    assert np.linalg.norm(written.base_T_camera[:3, 3] - truth[:3, 3]) < 0.005


def test_the_camera_pose_fits_the_corners_of_flat_markers(
    frame, markers, calibration: Calibration
) -> None:  # type: ignore[no-untyped-def]
    views = [(frame(name).grey, _known_markers(name, markers, flat_only=True)) for name in FRAMES]
    transform, residuals = fit_camera_pose(
        views, Calibration(calibration.camera_matrix), "DICT_4X4_250"
    )
    assert np.median(residuals) < 1.0
    truth = calibration.base_T_camera
    assert truth is not None
    assert np.linalg.norm(transform[:3, 3] - truth[:3, 3]) < 0.005
    assert np.abs(transform[:3, :3] - truth[:3, :3]).max() < 0.005
