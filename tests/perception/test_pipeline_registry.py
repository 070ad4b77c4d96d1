"""The perception pipelines are registered units: ``--pipeline`` looks them up, each is one
variant of the service's manifest, declaring exactly the messages its frames need and the
others it publishes."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

from manigraph_perception.calibration_file import Calibration
from manigraph_perception.manifest import MANIFEST
from manigraph_perception.pipeline import CameraSetup
from manigraph_perception.registry import PIPELINES, open_pipeline
from manigraph_perception.world_belief import WorldConfig
from manigraph_shared.errors import CONFIG_EXIT_CODE, ConfigError
from manigraph_shared.manifest import load_manifests
from manigraph_testkit.testing import Stack, free_port

ROOT = Path(__file__).resolve().parents[2]
CALIBRATION = str(ROOT / "examples" / "calibration" / "sim-front.yaml")


def test_the_manifest_variants_are_the_registered_pipelines() -> None:
    assert MANIFEST.variant_option == "pipeline"
    assert set(MANIFEST.variants) == set(PIPELINES) == {"aruco", "rgbd"}
    assert load_manifests()["perception"].variants == MANIFEST.variants


@pytest.mark.parametrize("name", ["aruco", "rgbd"])
def test_each_variant_declares_what_its_pipeline_reads_and_publishes(name: str) -> None:
    unit = PIPELINES[name]
    abilities = MANIFEST.abilities(name)
    consumes = {p.message for p in MANIFEST.consumes if p.ability is None or p.ability in abilities}
    produces = {p.message for p in MANIFEST.produces if p.ability is None or p.ability in abilities}
    assert set(unit.parts.values()) <= consumes
    assert set(unit.produces) <= produces
    # A port gated by this variant's abilities is one its pipeline uses, and nothing more.
    gated_in = {p.message for p in MANIFEST.consumes if p.ability in abilities}
    gated_out = {p.message for p in MANIFEST.produces if p.ability in abilities}
    assert gated_in <= set(unit.parts.values()) and gated_out <= set(unit.produces)


def test_the_variants_are_told_apart_by_what_they_bring() -> None:
    assert MANIFEST.abilities("aruco") != MANIFEST.abilities("rgbd")
    with pytest.raises(ConfigError, match="pipeline: 'nope' is not one of aruco, rgbd"):
        MANIFEST.abilities("nope")


def test_the_registry_names_every_pipeline_and_imports_none_until_one_is_opened() -> None:
    code = (
        "import sys; from manigraph_perception.registry import PIPELINES; "
        "print(PIPELINES.names(), sorted(m for m in sys.modules "
        "if m == 'cv2' or m.startswith('manigraph_perception.pipelines')))"
    )
    result = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert result.stdout.strip() == "['aruco', 'rgbd'] []", result.stderr
    assert set(PIPELINES["rgbd"].parts) == {"image", "depth"}  # opened: imported now


def test_an_option_of_another_pipeline_is_refused_by_name(calibration: Calibration) -> None:
    setup = CameraSetup("bus", "front", calibration, WorldConfig())
    with pytest.raises(ConfigError, match=r"pipeline.markers: not an option of pipeline 'rgbd'"):
        open_pipeline("rgbd", setup, markers="sim")
    with pytest.raises(ConfigError, match=r"markers: --pipeline aruco needs a marker map"):
        open_pipeline("aruco", setup)


@pytest.mark.integration
def test_an_unknown_pipeline_is_one_line_naming_the_known_ones(tmp_path: Path) -> None:
    running = Stack(free_port(), tmp_path)
    args = ["--pipeline", "lidar", "--camera", "bus", "--calibration", CALIBRATION]
    result = running.run("perception", *args, timeout=60)
    assert result.returncode == CONFIG_EXIT_CODE, result.stderr
    lines = result.stderr.strip().splitlines()
    assert lines[-1] == "manigraph perception: pipeline: 'lidar' is not one of: aruco, rgbd"
