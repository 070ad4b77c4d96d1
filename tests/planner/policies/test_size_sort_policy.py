"""The shipped size-sort GNN (checkpoints/size-sort/sage.pt, docs/tasks/size-sort.md) on
episodes it never saw, in one process: its success rate, not an exact outcome.

It was trained with ``manigraph train --arch sage --seed 0`` (the default sage recipe) on the
20 demonstrations of ``manigraph demos --task size-sort --blocks 3 4 5 6 --seed 0`` (episode
seeds 0-19). Seeds 7000-7099 were used for nothing else: at K = 4 it sorted 75 of 100
(measured once, 2026-12-06); the bound is that figure less a margin for a retrained
checkpoint.
"""

from __future__ import annotations

from pathlib import Path

from manigraph_lab.evaluate import EvalSpec, evaluate
from manigraph_planner.policies import load_policy

CHECKPOINT = Path(__file__).resolve().parents[3] / "checkpoints" / "size-sort" / "sage.pt"


def test_the_trained_policy_sorts_most_unseen_episodes() -> None:
    policy = load_policy(str(CHECKPOINT))
    summary = evaluate(policy, EvalSpec("size-sort", blocks=4, episodes=100, seed=7000))
    assert summary["episodes"] == 100
    assert float(summary["success_rate"]) >= 0.6, summary  # type: ignore[arg-type]
