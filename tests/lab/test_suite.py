"""The suite writes the table, the plot and the raw numbers (small settings: fast, real)."""

from __future__ import annotations

import json
import re
from hashlib import sha256
from pathlib import Path

import pytest

from manigraph_lab.generalization_suite import CURVE_K, cells, run_suite


@pytest.mark.slow
def test_suite_writes_table_plot_and_numbers(tmp_path: Path) -> None:
    summary = run_suite(tmp_path, ["gcn"], [0, 1], episodes=2, curve_episodes=1, epochs=2)
    table = (tmp_path / "generalization.md").read_text()
    assert "| paper |" in table and "| gcn |" in table
    gcn_row = next(line for line in table.splitlines() if line.startswith("| gcn |"))
    assert gcn_row.count("±") == len(cells(2))
    assert gcn_row.count("(min ") == len(cells(2))  # the worst seed beside the mean
    png = (tmp_path / "success_vs_k.png").read_bytes()
    assert png[:8] == b"\x89PNG\r\n\x1a\n" and len(png) > 10_000
    numbers = json.loads((tmp_path / "suite.json").read_text())
    assert all(len(v) == 2 for v in numbers["results"]["gcn"].values())
    assert set(numbers["curves"]["gcn"]) == {str(k) for k in CURVE_K}
    assert summary["seeds"] == [0, 1]
    # Checkpoints are reused on a second run instead of retrained.
    assert sorted(p.name for p in (tmp_path / "checkpoints").iterdir()) == [
        "gcn-seed0.pt",
        "gcn-seed1.pt",
    ]


@pytest.mark.slow
def test_suite_on_validation_seeds_without_the_curve(tmp_path: Path) -> None:
    summary = run_suite(
        tmp_path, ["gcn"], [0], episodes=1, curve_episodes=0, epochs=1, eval_seed=1000
    )
    assert summary["eval_seed"] == 1000
    assert "from seed 1000" in (tmp_path / "generalization.md").read_text()
    assert not (tmp_path / "success_vs_k.png").exists()
    assert summary["curves"] == {"gcn": {}}
    # Each policy by its file and digest; every float to 4 decimals at most.
    written = (tmp_path / "suite.json").read_text()
    checkpoint = tmp_path / "checkpoints" / "gcn-seed0.pt"
    assert json.loads(written)["checkpoints"] == {
        "gcn": {
            "0": {"path": str(checkpoint), "sha256": sha256(checkpoint.read_bytes()).hexdigest()}
        }
    }
    assert all(len(n.split(".")[1]) <= 4 for n in re.findall(r"\d+\.\d+", written))
