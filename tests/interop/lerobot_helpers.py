"""LeRobot's own loader, in a venv of its own, reading a dataset manigraph wrote.

``lerobot`` (with its ``dataset`` extra) needs Python >= 3.12, which the workspace (3.11) is
not, and brings its own torch and opencv, so it is not a workspace dependency:
:func:`lerobot_python` builds a venv once, cached under
``~/.cache/manigraph/lerobot-venv/lerobot-<version>`` (``MANIGRAPH_LEROBOT_VENV`` moves it),
with ``uv`` and a Python 3.12 or 3.13 (on PATH or pyenv's), and :func:`load_with_lerobot`
runs :data:`READER` there on a dataset folder and returns its JSON. The tests skip, saying
why, only where that venv cannot be built (no Python >= 3.12, or the package cannot be had).
"""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

LEROBOT_VERSION = "0.6.1"
LEROBOT_REQUIREMENT = f"lerobot[dataset]=={LEROBOT_VERSION}"

#: Runs in lerobot's venv: every frame through ``LeRobotDataset.__getitem__`` (torch tensors,
#: floats as float32 as LeRobot hands them to a policy), the float64 columns as its
#: ``hf_dataset`` holds them, and the episode boundaries from its metadata.
READER = r"""
import json, sys
from lerobot.datasets.lerobot_dataset import LeRobotDataset

ds = LeRobotDataset("manigraph/export", root=sys.argv[1])
frames = []
for i in range(len(ds)):
    item = ds[i]
    frame = {}
    for key, value in item.items():
        if key.startswith("observation.images."):
            frame[key] = (value * 255).round().to(dtype=__import__("torch").uint8).tolist()
        elif hasattr(value, "tolist"):
            frame[key] = value.tolist()
        else:
            frame[key] = value
    frames.append(frame)
raw = {
    name: ds.hf_dataset.data.column(name).to_pylist()
    for name in ("observation.nodes.position", "observation.nodes.orientation",
                 "observation.nodes.size", "observation.stamp")
}
episodes = [
    {key: ds.meta.episodes[e][key] for key in
     ("episode_index", "length", "dataset_from_index", "dataset_to_index", "tasks",
      "manigraph_episode_id")}
    for e in range(ds.meta.total_episodes)
]
print(json.dumps({
    "len": len(ds), "num_episodes": ds.num_episodes, "fps": ds.fps,
    "features": sorted(ds.features), "camera_keys": ds.meta.camera_keys,
    "stats_keys": sorted(ds.meta.stats), "episodes": episodes, "frames": frames, "raw": raw,
}))
"""


def _venv_root() -> Path:
    base = os.environ.get("MANIGRAPH_LEROBOT_VENV")
    root = Path(base) if base else Path.home() / ".cache" / "manigraph" / "lerobot-venv"
    return root / f"lerobot-{LEROBOT_VERSION}"


def _python_312() -> str | None:
    """A Python >= 3.12 that runs: on PATH, or one pyenv installed but did not select."""
    pyenv = Path(os.environ.get("PYENV_ROOT", Path.home() / ".pyenv")) / "versions"
    candidates = [shutil.which(name) for name in ("python3.13", "python3.12")]
    candidates += [str(p) for p in sorted(pyenv.glob("3.1[23]*/bin/python3.1[23]"), reverse=True)]
    for candidate in candidates:
        if candidate is None:
            continue
        probe = subprocess.run(
            [candidate, "-c", "import sys; print(sys.executable)"],
            capture_output=True,
            text=True,
            check=False,
        )
        if probe.returncode == 0:
            return probe.stdout.strip()
    return None


def _uv() -> list[str]:
    found = shutil.which("uv")
    return [found] if found else [sys.executable, "-m", "uv"]


def lerobot_python() -> Path:
    """The interpreter of a venv holding lerobot; built on first use (minutes), then reused."""
    venv = _venv_root()
    python = venv / "bin" / "python"
    if (venv / ".ready").is_file():
        return python
    interpreter = _python_312()
    if interpreter is None:
        pytest.skip(f"{LEROBOT_REQUIREMENT} needs Python >= 3.12; none is on PATH")
    shutil.rmtree(venv, ignore_errors=True)  # a half-built one (no .ready)
    venv.parent.mkdir(parents=True, exist_ok=True)
    steps = [
        [*_uv(), "venv", "--quiet", "--python", interpreter, str(venv)],
        [*_uv(), "pip", "install", "--quiet", "--python", str(python), LEROBOT_REQUIREMENT],
    ]
    for step in steps:
        done = subprocess.run(step, capture_output=True, text=True, timeout=1800, check=False)
        if done.returncode != 0:
            shutil.rmtree(venv, ignore_errors=True)
            pytest.skip(f"{LEROBOT_REQUIREMENT} could not be installed: {done.stderr[-500:]}")
    (venv / ".ready").write_text(LEROBOT_REQUIREMENT + "\n")
    return python


def load_with_lerobot(python: Path, dataset: Path, scratch: Path) -> dict[str, object]:
    """What ``LeRobotDataset`` reads from ``dataset`` (:data:`READER`'s JSON)."""
    script = scratch / "read_lerobot.py"
    script.write_text(READER)
    env = {
        **os.environ,
        "HF_HUB_OFFLINE": "1",  # a local folder: nothing to fetch
        "HF_HOME": str(scratch / "hf"),
        "HF_DATASETS_CACHE": str(scratch / "hf" / "datasets"),
    }
    done = subprocess.run(
        [str(python), str(script), str(dataset)],
        capture_output=True,
        text=True,
        timeout=600,
        env=env,
        check=False,
    )
    assert done.returncode == 0, done.stderr[-3000:]
    result = json.loads(done.stdout.strip().splitlines()[-1])
    assert isinstance(result, dict)
    return result
