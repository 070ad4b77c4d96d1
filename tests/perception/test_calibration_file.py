"""Calibration and layout files: read back what is written, refuse bad ones by field."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from manigraph_perception.calibration_file import Calibration, load_calibration
from manigraph_perception.layout_file import load_layout
from manigraph_shared.errors import ConfigError

ROOT = Path(__file__).resolve().parents[2]
K = np.array([[500.0, 0, 320], [0, 500, 240], [0, 0, 1]])


def test_a_calibration_round_trips(tmp_path: Path) -> None:
    pose = np.eye(4)
    pose[:3, 3] = [1.0, 0.0, 0.5]
    Calibration(K, np.arange(5) / 100, 640, 480, pose).save(tmp_path / "c.yaml")
    loaded = load_calibration(tmp_path / "c.yaml")
    assert np.allclose(loaded.camera_matrix, K) and np.allclose(loaded.base_T_camera, pose)
    assert np.allclose(loaded.distortion, np.arange(5) / 100)


def test_intrinsics_alone_are_refused_where_extrinsics_are_needed(tmp_path: Path) -> None:
    Calibration(K).save(tmp_path / "c.yaml")
    assert load_calibration(tmp_path / "c.yaml", need_extrinsics=False).base_T_camera is None
    with pytest.raises(ConfigError, match="base_T_camera"):
        load_calibration(tmp_path / "c.yaml")


@pytest.mark.parametrize(
    ("text", "field"),
    [
        ("%YAML:1.0\n---\nimage_width: 640\n", "camera_matrix"),
        ("not yaml at all: [", "calibration"),
    ],
)
def test_a_bad_calibration_names_the_field(tmp_path: Path, text: str, field: str) -> None:
    (tmp_path / "c.yaml").write_text(text)
    with pytest.raises(ConfigError, match=field):
        load_calibration(tmp_path / "c.yaml")


def test_a_singular_camera_matrix_is_refused() -> None:
    with pytest.raises(ConfigError, match="camera_matrix"):
        Calibration(np.zeros((3, 3)))


def test_a_missing_calibration_is_named(tmp_path: Path) -> None:
    with pytest.raises(ConfigError, match="calibration: no file"):
        load_calibration(tmp_path / "none.yaml")


def test_a_task_file_is_a_layout() -> None:
    layout = load_layout(ROOT / "examples" / "two-towers.toml")
    assert layout.objects and layout.goals and layout.episode_id == "live"


def test_a_bad_layout_names_the_field(tmp_path: Path) -> None:
    (tmp_path / "l.toml").write_text(
        '[[objects]]\nid = "b"\ncategory = "mug"\nposition = [0.5, 0, 0.02]\n'
        '[[goals]]\nid = "g"\ncategory = "block"\nposition = [0.4, 0, 0.02]\n'
    )
    with pytest.raises(ConfigError, match=r"layout\.objects\.0\.category"):
        load_layout(tmp_path / "l.toml")
