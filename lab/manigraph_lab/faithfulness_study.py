"""How faithful are the explanations? PyG's fidelity+/- and the top-edge rate, per objective.

For each task and shipped checkpoint, play seeded episodes until ``decisions`` decisions are
made, explain each with every explainer objective (same masks seed), and score it with
:func:`manigraph_planner.explain.faithfulness.faithfulness`: fid+ (the decision falls without
the explanation; higher is better), fid- (it does not hold on the explanation alone; lower is
better) and the share of explanations whose top edge touches the chosen object or goal.
``manigraph explain-faithfulness`` prints the table (docs/explainer-faithfulness.md).
"""

from __future__ import annotations

import sys
import time
from dataclasses import dataclass
from pathlib import Path
from typing import TextIO

from manigraph_lab.episode_loop import run_episode
from manigraph_planner.explain.config import ExplainerConfig, Objective
from manigraph_planner.explain.faithfulness import Faithfulness, faithfulness
from manigraph_planner.explain.masks import MaskExplainer
from manigraph_planner.gnn.features import scene_to_graph
from manigraph_planner.policies.gnn import GNNPolicy
from manigraph_shared.errors import ConfigError
from manigraph_shared.messages import EpisodeRequest, Scene

__all__ = ["TASKS", "Cell", "decisions_of", "measure", "table"]

#: (label, task, blocks, stacks): the issue's three tasks.
TASKS = (
    ("3-block 3-stack", "multistack", 3, 3),
    ("9-block stack", "stack", 9, 1),
    ("6-pyramid", "pyramid", 6, 1),
)


@dataclass(frozen=True)
class Cell:
    task: str
    arch: str
    objective: str
    decisions: int
    fid_plus: float
    fid_minus: float
    hard_fid_plus: float
    hard_fid_minus: float
    top_edge_touches: float
    ms_per_explanation: float


#: The explainer before issue #18: the whole-distribution objective at Adam step 0.1.
TODAY = ExplainerConfig(objective=Objective.DISTRIBUTION, learning_rate=0.1)


def config_for(objective: str) -> ExplainerConfig:
    """``distribution`` is the explainer as it was (:data:`TODAY`); any other objective runs
    with the default settings."""
    return TODAY if objective == Objective.DISTRIBUTION else ExplainerConfig(objective=objective)  # type: ignore[arg-type]


def decisions_of(
    policy: GNNPolicy, count: int, task: str, blocks: int, stacks: int, seed: int = 0
) -> list[tuple[Scene, str, str]]:
    """The first ``count`` decisions (scene, object, goal) of seeded episodes of ``task``."""
    found: list[tuple[Scene, str, str]] = []
    episode = 0
    while len(found) < count and episode < 10 * count:
        request = EpisodeRequest(
            episode_id=f"faith-{task}-{seed + episode}",
            task=task,
            blocks=blocks,
            stacks=stacks,
            seed=seed + episode,
        )
        record = run_episode(policy, request)
        episode += 1
        found += [(s.scene, s.action.object_id, s.action.goal_id) for s in record.steps]
    return found[:count]


def measure(
    policy: GNNPolicy,
    decisions: list[tuple[Scene, str, str]],
    config: ExplainerConfig,
) -> tuple[list[Faithfulness], float]:
    """Each decision's figures under ``config``, and the mean milliseconds per explanation."""
    explainer = MaskExplainer(policy.net, config)
    scores = []
    started = time.perf_counter()
    for scene, object_id, goal_id in decisions:
        graph = scene_to_graph(scene)
        o = graph.object_ids.index(object_id)
        g = graph.num_objects + graph.goal_ids.index(goal_id)
        result = explainer.explain(graph.x, graph.edge_index, graph.num_objects, o, g)
        scores.append(faithfulness(explainer.net, graph.x, graph.num_objects, result))
    ms = 1000 * (time.perf_counter() - started) / max(len(decisions), 1)
    return scores, ms


def run(
    checkpoints: dict[str, Path],
    count: int = 100,
    objectives: tuple[str, ...] = ("distribution", "pair-context"),
    progress: TextIO | None = sys.stderr,
) -> list[Cell]:
    if count < 1:
        raise ConfigError("decisions", f"must be >= 1, got {count}")
    cells = []
    for label, task, blocks, stacks in TASKS:
        for arch, path in checkpoints.items():
            policy = GNNPolicy.from_checkpoint(path)
            decisions = decisions_of(policy, count, task, blocks, stacks)
            for objective in objectives:
                scores, ms = measure(policy, decisions, config_for(objective))
                n = max(len(scores), 1)
                cell = Cell(
                    task=label,
                    arch=arch,
                    objective=objective,
                    decisions=len(scores),
                    fid_plus=sum(s.lost for s in scores) / n,
                    fid_minus=sum(not s.kept for s in scores) / n,
                    hard_fid_plus=sum(s.hard_lost for s in scores) / n,
                    hard_fid_minus=sum(not s.hard_kept for s in scores) / n,
                    top_edge_touches=sum(s.top_edge_touches for s in scores) / n,
                    ms_per_explanation=ms,
                )
                cells.append(cell)
                if progress is not None:
                    print(f"  {table_row(cell)}", file=progress, flush=True)
    return cells


def table_row(cell: Cell) -> str:
    return (
        f"| {cell.task} | {cell.arch} | {cell.objective} | {cell.decisions} | "
        f"{cell.fid_plus:.2f} | {cell.fid_minus:.2f} | {cell.top_edge_touches:.2f} | "
        f"{cell.hard_fid_plus:.2f} | {cell.hard_fid_minus:.2f} | "
        f"{cell.ms_per_explanation:.0f} |"
    )


def table(cells: list[Cell]) -> str:
    head = (
        "| task | arch | objective | decisions | fid+ | fid- | top edge on chosen pair "
        "| hard fid+ | hard fid- | ms per explanation |\n"
        "|---|---|---|---|---|---|---|---|---|---|"
    )
    return "\n".join([head, *(table_row(c) for c in cells)])
