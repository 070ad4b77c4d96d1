"""Selection keeps the candidate with the best validation success, on episodes no report uses."""

from __future__ import annotations

from pathlib import Path

import pytest

from manigraph_lab.generalization_suite import cells
from manigraph_lab.selection import (
    VALIDATION_SEED,
    Candidate,
    best,
    select_checkpoint,
    validation_cells,
)
from manigraph_planner.gnn import load_checkpoint

CHECKPOINTS = Path(__file__).resolve().parents[2] / "checkpoints"


def test_best_is_the_highest_mean_and_the_earliest_among_equals() -> None:
    a = Candidate(Path("a.pt"), {"x": 1.0, "y": 0.0})
    b = Candidate(Path("b.pt"), {"x": 0.5, "y": 1.0})
    c = Candidate(Path("c.pt"), {"x": 1.0, "y": 0.5})
    assert best([a, b, c]) is b
    assert best([c, b]) is c  # equal means: the first listed


def test_validation_episodes_are_the_suites_cells_on_other_seeds() -> None:
    validation, reported = validation_cells(7), cells(7)
    assert [c.label for c in validation] == [c.label for c in reported]
    for v, r in zip(validation, reported, strict=True):
        assert (v.spec.task, v.spec.blocks, v.spec.stacks, v.spec.noise) == (
            r.spec.task,
            r.spec.blocks,
            r.spec.stacks,
            r.spec.noise,
        )
        assert v.spec.seed == VALIDATION_SEED and r.spec.seed + r.spec.episodes <= v.spec.seed


@pytest.mark.slow
def test_select_writes_the_better_checkpoint_with_every_candidates_scores(tmp_path: Path) -> None:
    # The shipped sage solves K = 40 stacking, which the shipped gated fails (README table).
    candidates = [CHECKPOINTS / "gated.pt", CHECKPOINTS / "sage.pt"]
    out = tmp_path / "kept.pt"
    chosen, table = select_checkpoint(candidates, out, episodes=3, progress=None)
    assert chosen.path.name == "sage.pt"
    _, info = load_checkpoint(out)
    assert info.architecture == "sage"
    selection = info.metrics["selection"]
    assert selection["kept"] == "sage.pt" and selection["validation_seed"] == VALIDATION_SEED
    assert set(selection["candidates"]) == {"gated.pt", "sage.pt"}
    assert selection["candidates"]["sage.pt"] == chosen.scores
    assert "| sage.pt (kept) |" in table and "| gated.pt |" in table
