"""Every ``manigraph`` process builds its parser from every installed subcommand, so a
subcommand module that imports a heavy library at module level slows down every process (the
router's too): torch alone took 10-90 s on a busy 2-core machine."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

HEAVY = ("torch", "torch_geometric", "sapien", "pinocchio", "mani_skill", "cv2")

LOAD_EVERY_COMMAND = f"""
import sys
from pathlib import Path
from importlib.metadata import entry_points
for entry in entry_points(group="manigraph.commands"):
    entry.load()
print(",".join(name for name in {HEAVY!r} if name in sys.modules))
"""


def test_loading_every_subcommand_imports_no_heavy_library() -> None:
    done = subprocess.run(
        [sys.executable, "-c", LOAD_EVERY_COMMAND], capture_output=True, text=True, check=True
    )
    assert done.stdout.strip() == "", f"imported at start-up: {done.stdout.strip()}"


SERVE_THE_EXPERT = """
import sys
from pathlib import Path
from manigraph_planner.decisions import DecisionHistory
from manigraph_planner.explain import ExplainHandler
from manigraph_planner.policies import load_policy
from manigraph_planner.service import PlannerService

handler = ExplainHandler(load_policy("expert"), DecisionHistory())
print(handler.available, "torch" in sys.modules)
print(handler.problem)
"""


def test_the_planner_serving_the_expert_imports_no_torch() -> None:
    done = subprocess.run(
        [sys.executable, "-c", SERVE_THE_EXPERT], capture_output=True, text=True, check=True
    )
    flags, problem = done.stdout.strip().splitlines()
    assert flags == "False False"  # not explainable, and torch never imported
    assert "'expert' is not a GNN policy" in problem


SERVE_A_CHECKPOINT = """
import sys
from pathlib import Path
from manigraph_planner.decisions import DecisionHistory
from manigraph_planner.explain import ExplainHandler
from manigraph_planner.policies import load_policy

policy = load_policy(sys.argv[1])
handler = ExplainHandler(policy, DecisionHistory())
print(handler.available, "torch_geometric" in sys.modules)
handler.prepare()  # the explainer: dense layers on the planner's own weights, no PyG
print("torch_geometric" in sys.modules)
"""


def test_the_planner_serving_and_explaining_a_checkpoint_imports_no_pyg() -> None:
    """PyG (and the torch._dynamo it imports) cost ~2 s of the planner's start-up, and made
    the explainer ready seconds after the planner."""
    checkpoint = Path(__file__).resolve().parents[2] / "checkpoints" / "sage.pt"
    done = subprocess.run(
        [sys.executable, "-c", SERVE_A_CHECKPOINT, str(checkpoint)],
        capture_output=True,
        text=True,
        check=True,
    )
    assert done.stdout.split() == ["True", "False", "False"], done.stdout
