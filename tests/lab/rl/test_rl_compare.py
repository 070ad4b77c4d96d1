"""``rl-compare``: resumable stages, the report, and the command line."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import pytest

import manigraph_lab.rl.compare as compare
from manigraph_lab.rl.baselines import BASELINES, PPOSettings
from manigraph_lab.rl.compare import CompareSpec, RunStore, run_comparison, train_baseline
from manigraph_shared.cli import build_parser
from manigraph_shared.errors import ConfigError

TINY = PPOSettings(
    steps_per_stage=16, n_steps=16, batch_size=8, n_epochs=1, blocks=(2, 3), hidden_channels=8
)
SAGE = Path(__file__).resolve().parents[3] / "checkpoints" / "sage.pt"


@pytest.fixture
def trained(monkeypatch: pytest.MonkeyPatch) -> list[str]:
    """Names of the stages actually trained (not skipped) during the test."""
    names: list[str] = []
    real = compare.train_stage

    def counting(baseline: Any, stage: Any, *args: Any) -> dict[str, Any]:
        names.append(f"{baseline.name}/{stage.name}")
        return real(baseline, stage, *args)

    monkeypatch.setattr(compare, "train_stage", counting)
    return names


def test_a_rerun_skips_finished_stages_and_redoes_only_missing_ones(
    tmp_path: Path, trained: list[str]
) -> None:
    store = RunStore(tmp_path, TINY)
    seq = BASELINES["rl-gnn-seq"]
    first = train_baseline(seq, 0, store, lambda: [])
    assert trained == ["rl-gnn-seq/K2", "rl-gnn-seq/K3"]
    again = train_baseline(seq, 0, store, lambda: [])
    assert trained == ["rl-gnn-seq/K2", "rl-gnn-seq/K3"]  # nothing retrained
    assert [r["stage"] for r in again] == ["K2", "K3"] and again[0] == {
        **first[0],
        "settings": TINY.to_dict(),
    }
    # An interruption during K3: its record never got written.
    (store.folder("rl-gnn-seq", 0) / "K3.json").unlink()
    train_baseline(seq, 0, store, lambda: [])
    assert trained[2:] == ["rl-gnn-seq/K3"]


def test_a_run_with_other_settings_is_refused(tmp_path: Path) -> None:
    train_baseline(BASELINES["rl-gnn"], 0, RunStore(tmp_path, TINY), lambda: [])
    other = PPOSettings(**{**TINY.to_dict(), "blocks": (2, 3), "learning_rate": 0.1})
    with pytest.raises(ConfigError, match="out"):
        train_baseline(BASELINES["rl-gnn"], 0, RunStore(tmp_path, other), lambda: [])


def test_comparison_writes_table_plot_and_json_and_resumes(
    tmp_path: Path, trained: list[str]
) -> None:
    spec = CompareSpec(
        out=tmp_path,
        baselines=("rl-mlp", "rl-gnn-seq"),
        seeds=(0, 1),
        episodes=2,
        il_checkpoints=(SAGE,),
        explain_decisions=2,
        explain_blocks=3,
        settings=TINY,
    )
    results = run_comparison(spec, show_progress=False)
    assert len(trained) == 2 * 2 * 2
    table = (tmp_path / "table.md").read_text()
    for row in ("| RL-MLP |", "| RL-GNN-Seq |", "| IL-GNN (sage) |", "K=3", "32 per baseline"):
        assert row in table
    assert (tmp_path / "success_vs_k.png").read_bytes().startswith(b"\x89PNG")
    saved = json.loads((tmp_path / "results.json").read_text())
    assert saved["methods"]["rl-gnn-seq"]["per_seed"].keys() == {"0", "1"}
    assert saved["methods"]["il-sage"]["mean"] == {"2": 1.0, "3": 1.0}
    assert set(results["explain"]["policies"]) == {
        "RL-GNN-Seq (seed 0, stage K3)",
        "IL-GNN (sage)",
    }
    run_comparison(spec, show_progress=False)
    assert len(trained) == 8  # the rerun trained nothing
    assert json.loads((tmp_path / "results.json").read_text())["methods"] == saved["methods"]


def test_command_is_registered_and_validates() -> None:
    args = build_parser().parse_args(["rl-compare", "--seeds", "0", "--json"])
    assert args.out == Path("results/rl") and args.seeds == [0]
    with pytest.raises(ConfigError, match="baselines"):
        CompareSpec(baselines=("rl-transformer",))
    with pytest.raises(ConfigError, match="seeds"):
        CompareSpec(seeds=(1, 1))


def test_an_evaluation_is_reused_only_for_the_same_model_files(tmp_path: Path) -> None:
    store = RunStore(tmp_path, TINY)
    gnn = BASELINES["rl-gnn"]
    train_baseline(gnn, 0, store, lambda: [])
    fresh = compare.evaluate_baseline(gnn, 0, store, episodes=1)
    path = store.folder("rl-gnn", 0) / "eval.json"
    saved = json.loads(path.read_text())
    saved["per_k"]["2"]["success_rate"] = 0.5  # marks a cached answer
    path.write_text(json.dumps(saved))
    assert compare.evaluate_baseline(gnn, 0, store, episodes=1)["2"]["success_rate"] == 0.5
    saved["models"]["part2"] = "an older model"
    path.write_text(json.dumps(saved))
    assert compare.evaluate_baseline(gnn, 0, store, episodes=1) == fresh
