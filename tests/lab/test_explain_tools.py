"""The explainer's lab tools: the picture, offline explanations from a log, the study."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
import torch

from manigraph_lab.decision_explanations import explain_offline, summary
from manigraph_lab.demo_recording import DemoProtocol, record_demos
from manigraph_lab.explain_viz import render_explanation
from manigraph_lab.explanation_study import StudySpec, markdown_table, run_study, summarise
from manigraph_planner.gnn.checkpoint import save_checkpoint
from manigraph_planner.gnn.models import ModelConfig, PolicyNet
from manigraph_planner.policies import load_policy
from manigraph_shared.errors import ConfigError, LogError

PNG_MAGIC = b"\x89PNG\r\n\x1a\n"


@pytest.fixture(scope="module")
def demo_log(tmp_path_factory: pytest.TempPathFactory) -> Path:
    path = tmp_path_factory.mktemp("demos") / "demos.mcap"
    record_demos(load_policy("expert"), DemoProtocol(("multistack",), (3,), 1, 0), path)
    return path


@pytest.fixture(scope="module")
def checkpoint(tmp_path_factory: pytest.TempPathFactory) -> Path:
    torch.manual_seed(0)
    path = tmp_path_factory.mktemp("ckpt") / "gcn.pt"
    return save_checkpoint(path, PolicyNet(ModelConfig("gcn")), training_config={}, data_hash="h")


def test_a_logged_decision_is_explained_offline_and_drawn(
    demo_log: Path, checkpoint: Path, tmp_path: Path
) -> None:
    explanation, note = explain_offline(checkpoint, demo_log, "demo-000-multistack:1", seed=0)
    assert explanation.decision_id == "demo-000-multistack:1"
    assert explanation.policy == "gnn-gcn"
    if (explanation.object, explanation.goal) != ("block_1", "goal_1"):
        assert "the log recorded" in note  # an untrained net disagrees with the expert
    data = summary(explanation)
    assert list(data)[:6] == ["decision_id", "object", "goal", "edges", "features", "sentence"]
    json.dumps(data)  # plain JSON
    png = render_explanation(explanation, tmp_path / "sub" / "why.png", views=("xz",))
    assert png.read_bytes()[:8] == PNG_MAGIC
    last, _ = explain_offline(checkpoint, demo_log, None, seed=0)
    assert last.decision_id == "demo-000-multistack:2"  # the last recorded decision


def test_offline_mistakes_name_what_is_wrong(
    demo_log: Path, checkpoint: Path, tmp_path: Path
) -> None:
    with pytest.raises(LogError, match="decision: 'x:9' is not a decision recorded"):
        explain_offline(checkpoint, demo_log, "x:9", seed=0)
    with pytest.raises(LogError, match="scene-from: no such file"):
        explain_offline(checkpoint, tmp_path / "missing.mcap", None, seed=0)
    explanation, _ = explain_offline(checkpoint, demo_log, None, seed=0)
    with pytest.raises(ConfigError, match="views: 'top'"):
        render_explanation(explanation, tmp_path / "x.png", views=("top",))
    with pytest.raises(ConfigError, match="nodes"):
        render_explanation(explanation.replace(nodes=[]), tmp_path / "x.png")


def test_the_study_writes_a_table_of_top_features(tmp_path: Path) -> None:
    spec = StudySpec(archs=("sage",), trajectories=(1,), decisions=3, epochs=1)
    table = run_study(spec, tmp_path)
    assert "| Num. traj | sage |" in table
    row = next(line for line in table.splitlines() if line.startswith("| 1 |"))
    names = {"category", "x", "y", "z", "unfilled"}
    assert {name.strip() for name in row.split("|")[2].split(",")} <= names
    assert (tmp_path / "table.md").read_text().strip() == table.strip()
    cells = json.loads((tmp_path / "explanations.json").read_text())["cells"]
    assert cells["sage/1"]["decisions"] == 3
    assert sum(cells["sage/1"]["top1_counts"].values()) == 3


def test_study_settings_are_checked_and_cells_summarised() -> None:
    with pytest.raises(ConfigError, match="trajectories"):
        StudySpec(trajectories=(0,))
    with pytest.raises(ConfigError, match="decisions"):
        StudySpec(decisions=0)
    assert summarise([])["decisions"] == 0
    spec = StudySpec(archs=("gcn",), trajectories=(5,))
    cell = {
        "top1_counts": {"z": 3},
        "top2_counts": {"filled": 2},
        "edges_touch_object_rate": 1.0,
        "top_edge_touches_object_rate": 1.0,
        "success_rate": 0.5,
    }
    assert "| 5 | z, unfilled |" in markdown_table(spec, {"gcn/5": cell})
