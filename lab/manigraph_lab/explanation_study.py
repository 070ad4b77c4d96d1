"""The paper's Table "gnn": the two most important features per architecture and data size.

For each training-set size (the paper: 5 vs 15,000 trajectories) and architecture, train a
policy by imitation, let it act on the 3-block 3-stack task (``multistack``, K = 3, s = 3)
until ``decisions`` decisions are made, explain each decision, and report per cell the
feature most often ranked first and the feature most often ranked second (so a cell can read
"z, z", as the paper's GCN row does). ``explanations.json`` keeps every count and mean.
"""

from __future__ import annotations

import json
from collections import Counter
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import TextIO

from manigraph_lab.demo_recording import DemoProtocol, record_demos
from manigraph_lab.episode_loop import run_episode
from manigraph_planner.policies.base import Policy
from manigraph_shared.errors import ConfigError
from manigraph_shared.messages import EpisodeRequest, Explanation
from manigraph_shared.progress import Progress

__all__ = ["StudySpec", "collect_explanations", "edges_touch_object", "run_study"]

#: The paper's name for the ``filled`` feature in its table.
PAPER_NAMES = {"filled": "unfilled"}


@dataclass(frozen=True)
class StudySpec:
    """Which cells to fill and how. Raises ``ConfigError`` naming the field."""

    archs: tuple[str, ...] = ("gat", "gated", "gcn", "sage")
    trajectories: tuple[int, ...] = (5, 100)
    decisions: int = 100
    epochs: int = 150
    seed: int = 0
    demo_tasks: tuple[str, ...] = ("box-pack", "box-unpack")
    demo_blocks: tuple[int, ...] = (3, 4)
    task: str = "multistack"
    blocks: int = 3
    stacks: int = 3

    def __post_init__(self) -> None:
        if not self.archs:
            raise ConfigError("archs", "name at least one architecture")
        if not self.trajectories or min(self.trajectories) < 1:
            raise ConfigError("trajectories", f"each must be >= 1, got {self.trajectories}")
        for name in ("decisions", "epochs"):
            if getattr(self, name) < 1:
                raise ConfigError(name, f"must be >= 1, got {getattr(self, name)}")
        if self.seed < 0:
            raise ConfigError("seed", f"must be >= 0, got {self.seed}")


def edges_touch_object(explanation: Explanation) -> bool:
    """Whether every kept edge starts or ends on the chosen object (the paper: always)."""
    return all(explanation.object in (e.src, e.dst) for e in explanation.edges)


def collect_explanations(
    policy: Policy,
    count: int,
    task: str = "multistack",
    blocks: int = 3,
    stacks: int = 3,
    seed: int = 0,
    explain_seed: int = 0,
    progress: TextIO | None = None,
) -> tuple[list[Explanation], int, int]:
    """Run seeded episodes until ``count`` decisions are made; explain each one.

    Returns the explanations, the number of episodes and how many of them succeeded.
    ``progress``: stream for a bar over the decisions, drawn only on a terminal.
    """
    from manigraph_planner.explain import SceneExplainer

    explainer = SceneExplainer(policy)
    explanations: list[Explanation] = []
    episodes = successes = 0
    bar = Progress(count, f"explain {policy.name}", unit="decision", stream=progress)
    while len(explanations) < count:
        request = EpisodeRequest(
            episode_id=f"explain-{task}-{blocks}x{stacks}-{seed + episodes}",
            task=task,
            blocks=blocks,
            stacks=stacks,
            seed=seed + episodes,
        )
        record = run_episode(policy, request)
        episodes += 1
        successes += record.success
        if not record.steps and episodes > 10 * count:
            break  # the policy never decides: nothing to explain
        for step in record.steps[: count - len(explanations)]:
            explanations.append(
                explainer.explain(
                    step.scene,
                    step.action.object_id,
                    step.action.goal_id,
                    step.action.decision_id,
                    explain_seed,
                )
            )
            bar.update()
    bar.close()
    return explanations, episodes, successes


def summarise(explanations: list[Explanation]) -> dict[str, object]:
    """Rank counts, mean importances and the edge-touch rate of a cell."""
    first: Counter[str] = Counter()
    second: Counter[str] = Counter()
    totals: Counter[str] = Counter()
    for e in explanations:
        ranked = list(e.features)
        first[ranked[0]] += 1
        if len(ranked) > 1:
            second[ranked[1]] += 1
        totals.update(e.features)
    n = max(len(explanations), 1)
    return {
        "decisions": len(explanations),
        "top1_counts": dict(first.most_common()),
        "top2_counts": dict(second.most_common()),
        "mean_importance": {k: round(v / n, 4) for k, v in totals.most_common()},
        "edges_touch_object_rate": sum(map(edges_touch_object, explanations)) / n,
        "top_edge_touches_object_rate": sum(
            bool(e.edges) and e.object in (e.edges[0].src, e.edges[0].dst) for e in explanations
        )
        / n,
    }


def cell_text(cell: dict[str, object]) -> str:
    """ "z, unfilled": the most frequent first- and second-ranked features."""
    names = []
    for key in ("top1_counts", "top2_counts"):
        counts = cell[key]
        assert isinstance(counts, dict)
        names.append(PAPER_NAMES.get(next(iter(counts)), next(iter(counts))) if counts else "-")
    return ", ".join(names)


def run_study(spec: StudySpec, out: Path, progress: TextIO | None = None) -> str:
    """Fill every cell, write ``table.md`` and ``explanations.json`` under ``out``; return the
    Markdown table. ``progress``: stream for bars (drawn on a terminal only) and for one line
    per cell."""
    from manigraph_planner.policies import load_policy
    from manigraph_planner.policies.gnn import GNNPolicy
    from manigraph_training.dataset import load_demonstrations
    from manigraph_training.trainer import TrainConfig, train

    out.mkdir(parents=True, exist_ok=True)
    cells: dict[str, dict[str, object]] = {}
    work = len(spec.trajectories) * len(spec.archs)
    bar = Progress(work, "explain-study", unit="cell", stream=progress)
    for size in spec.trajectories:
        demo_log = out / f"demos-{size}.mcap"
        protocol = DemoProtocol(spec.demo_tasks, spec.demo_blocks, size, spec.seed)
        record_demos(load_policy("expert"), protocol, demo_log, progress=progress)
        demos = load_demonstrations([demo_log])
        for arch in spec.archs:
            bar.status(f"{arch}, {size} trajectories")
            config = TrainConfig(architecture=arch, seed=spec.seed, epochs=spec.epochs)
            net, metrics = train(demos, config, progress=progress)
            explanations, episodes, successes = collect_explanations(
                GNNPolicy(net),
                spec.decisions,
                spec.task,
                spec.blocks,
                spec.stacks,
                spec.seed,
                progress=progress,
            )
            cell = summarise(explanations)
            cell.update(
                episodes=episodes,
                success_rate=successes / max(episodes, 1),
                demo_accuracy=metrics["demo_accuracy"],
            )
            cells[f"{arch}/{size}"] = cell
            bar.note(f"  {arch}, {size} trajectories: {cell_text(cell)}")
            bar.update()
    bar.close()
    table = markdown_table(spec, cells)
    (out / "table.md").write_text(table + "\n")
    (out / "explanations.json").write_text(
        json.dumps({"spec": asdict(spec), "cells": cells}, indent=2) + "\n"
    )
    return table


def markdown_table(spec: StudySpec, cells: dict[str, dict[str, object]]) -> str:
    """Rows: training-set size; columns: architecture; cell: the top-2 features. A second
    table gives, per cell, how often the kept edges all touch the chosen object, how often the
    top edge does, and the episode success rate."""
    head = "| Num. traj | " + " | ".join(spec.archs) + " |"
    rule = "|---|" + "---|" * len(spec.archs)
    lines = [
        f"Top-2 features, {spec.task} K={spec.blocks} s={spec.stacks}, {spec.decisions} "
        f"decisions per cell, {spec.epochs} epochs, seed {spec.seed}",
        "",
        head,
        rule,
    ]
    for size in spec.trajectories:
        row = [cell_text(cells[f"{arch}/{size}"]) for arch in spec.archs]
        lines.append(f"| {size} | " + " | ".join(row) + " |")
    lines += ["", "All kept edges touch the chosen object / top edge does / success rate:", ""]
    lines += [head, rule]
    for size in spec.trajectories:
        row = []
        for arch in spec.archs:
            cell = cells[f"{arch}/{size}"]
            row.append(
                f"{cell['edges_touch_object_rate']:.2f} / "
                f"{cell['top_edge_touches_object_rate']:.2f} / {cell['success_rate']:.2f}"
            )
        lines.append(f"| {size} | " + " | ".join(row) + " |")
    return "\n".join(lines)
