"""The Panda description ships with manigraph_shared: URDF, every mesh it references, licence,
and the wheel the Docker images install carries them."""

from __future__ import annotations

import re
import shutil
import subprocess
import sys
import zipfile
from pathlib import Path

import pytest

import manigraph_shared
from manigraph_shared.panda import SHIPPED_PANDA, panda_urdf_path

ROOT = Path(__file__).resolve().parents[2]


def referenced(urdf: Path) -> set[str]:
    return set(re.findall(r'filename="([^"]+)"', urdf.read_text()))


def test_the_urdf_is_the_shipped_copy_with_every_mesh_and_its_licence() -> None:
    urdf = panda_urdf_path()
    assert urdf.parent == SHIPPED_PANDA
    assert SHIPPED_PANDA.is_relative_to(Path(manigraph_shared.__file__).parent)
    meshes = referenced(urdf)
    assert len(meshes) == 19  # 9 collision meshes, 10 visual ones
    for mesh in meshes:
        assert (SHIPPED_PANDA / mesh).is_file(), mesh
    assert "Apache License" in (SHIPPED_PANDA / "LICENSE").read_text()
    assert "franka_ros" in (SHIPPED_PANDA / "NOTICE").read_text()


@pytest.mark.slow
def test_the_wheel_carries_the_description(tmp_path: Path) -> None:
    uv = [sys.executable, "-m", "uv"] if shutil.which("uv") is None else ["uv"]
    subprocess.run(
        [*uv, "build", "--wheel", str(ROOT / "shared"), "-o", str(tmp_path), "-q"],
        check=True,
        timeout=120,
    )
    (wheel,) = tmp_path.glob("*.whl")
    names = set(zipfile.ZipFile(wheel).namelist())
    prefix = "manigraph_shared/robots/panda/"
    for mesh in referenced(panda_urdf_path()):
        assert prefix + mesh in names
    assert {prefix + "panda_v2.urdf", prefix + "LICENSE", prefix + "NOTICE"} <= names
