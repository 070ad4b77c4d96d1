"""The serving planner carries no training (issue #50, item 4): its package declares neither
pyarrow nor the training package, and serving every shipped checkpoint and every family's
expert imports neither ``manigraph_training``, a family's training part, nor pyarrow."""

from __future__ import annotations

import json
import subprocess
import sys
import tomllib
from pathlib import Path

REPO = Path(__file__).resolve().parents[2]

#: What serving must not import: the training package, a family's training part, pyarrow.
TRAINING_ONLY = (
    "manigraph_training",
    "pyarrow",
    "manigraph_blocks.training",
    "manigraph_dishwasher.training",
)

SERVE = """
import json, sys
from pathlib import Path
from manigraph_planner.family import FAMILIES
from manigraph_planner.policies import load_policy
from manigraph_shared.messages import EpisodeRequest
for name, family in FAMILIES.items():
    family.expert(EpisodeRequest(episode_id="e", task="stack"))
for checkpoint in sorted(Path(sys.argv[1]).glob("*.pt")):
    load_policy(str(checkpoint))
print(json.dumps(sorted(sys.modules)))
"""


def test_the_planner_declares_no_pyarrow_and_no_training_package() -> None:
    project = tomllib.loads((REPO / "services/planner/pyproject.toml").read_text())["project"]
    names = [
        dependency.split("=")[0].split(">")[0].strip() for dependency in project["dependencies"]
    ]
    assert "pyarrow" not in names and "manigraph-training" not in names
    assert "train" not in project["entry-points"]["manigraph.commands"]


def test_serving_every_shipped_checkpoint_imports_no_training() -> None:
    checkpoints = REPO / "checkpoints"
    assert len(list(checkpoints.glob("*.pt"))) >= 4  # the shipped policies are there to load
    done = subprocess.run(
        [sys.executable, "-c", SERVE, str(checkpoints)],
        capture_output=True,
        text=True,
        timeout=240,
        check=True,
    )
    modules = json.loads(done.stdout.splitlines()[-1])
    assert "manigraph_planner.policies.gnn" in modules  # a GNN policy was really loaded
    loaded = [m for m in modules for part in TRAINING_ONLY if m == part or m.startswith(f"{part}.")]
    assert loaded == []
