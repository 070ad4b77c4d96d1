"""The serving planner carries no training (issue #50, item 4): its package declares neither
pyarrow, torch-geometric nor the training package, and in a process where PyG cannot be
imported it still decides with every shipped checkpoint and explains a block decision,
importing neither ``manigraph_training``, a family's training part, pyarrow nor PyG."""

from __future__ import annotations

import json
import re
import subprocess
import sys
import tomllib
from pathlib import Path

REPO = Path(__file__).resolve().parents[2]

#: What serving must not import: the training package, a family's training part, pyarrow, PyG.
TRAINING_ONLY = (
    "manigraph_training",
    "manigraph_blocks.training",
    "manigraph_dishwasher.training",
    "pyarrow",
    "torch_geometric",
)

#: A planner process without PyG (an import of it fails, as where it is not installed): it
#: decides on a scene of its family with each shipped checkpoint, explains a block decision,
#: and prints the modules it imported; then asks for the message-passing twin and prints the
#: refusal.
SERVE = """
import json, sys
sys.modules["torch_geometric"] = None  # import torch_geometric: ImportError
from pathlib import Path
from manigraph_planner.explain.scene_explainer import SceneExplainer
from manigraph_planner.explain.config import ExplainerConfig
from manigraph_planner.family import FAMILIES
from manigraph_planner.gnn.models.build import with_message_passing
from manigraph_planner.policies import load_policy
from manigraph_shared.messages import EpisodeRequest
from manigraph_sim.geometric.backend import GeometricBackend

def first_scene(task, **request):
    backend = GeometricBackend()
    backend.reset(EpisodeRequest(episode_id="e", task=task, **request), 0.0)
    return backend.scene(1.0)

scenes = {
    "stack": first_scene("stack", blocks=4),
    "dishwasher": first_scene("dishwasher", objects=4),
}
for name, family in FAMILIES.items():
    family.expert(EpisodeRequest(episode_id="e", task="stack"))
decided = {}
for checkpoint in sorted(Path(sys.argv[1]).glob("*.pt")):
    policy = load_policy(str(checkpoint))
    task = "dishwasher" if checkpoint.name.startswith("dishwasher") else "stack"
    decided[checkpoint.name] = policy.decide(scenes[task]) is not None
sage = load_policy(str(Path(sys.argv[1]) / "sage.pt"))
explained = SceneExplainer(sage, ExplainerConfig(steps=3)).explain_scene(scenes["stack"])
modules = sorted(name for name, module in sys.modules.items() if module is not None)
try:
    with_message_passing(sage.net)
    refusal = ""
except Exception as error:
    refusal = str(error)
print(json.dumps({"decided": decided, "explained": explained.object, "modules": modules,
                  "refusal": refusal}))
"""


def _names(dependencies: list[str]) -> set[str]:
    return {re.split(r"[<>=!~\[; ]", dependency, maxsplit=1)[0] for dependency in dependencies}


def test_the_planner_declares_no_training_package_pyarrow_or_pyg() -> None:
    project = tomllib.loads((REPO / "services/planner/pyproject.toml").read_text())["project"]
    assert (
        _names(project["dependencies"])
        & {
            "pyarrow",
            "torch-geometric",
            "manigraph-training",
        }
        == set()
    )
    assert "train" not in project["entry-points"]["manigraph.commands"]


def test_the_planner_serves_every_shipped_checkpoint_without_training_or_pyg() -> None:
    checkpoints = REPO / "checkpoints"
    assert len(list(checkpoints.glob("*.pt"))) >= 4  # the shipped policies are there to load
    done = subprocess.run(
        [sys.executable, "-c", SERVE, str(checkpoints)],
        capture_output=True,
        text=True,
        timeout=240,
        check=True,
    )
    served = json.loads(done.stdout.splitlines()[-1])
    assert served["decided"] and all(served["decided"].values()), served["decided"]
    assert served["explained"]  # the explainer ran on the dense path
    loaded = [
        module
        for module in served["modules"]
        for part in TRAINING_ONLY
        if module == part or module.startswith(f"{part}.")
    ]
    assert loaded == []
    assert served["refusal"].startswith("message passing: this network needs PyG's layers")
