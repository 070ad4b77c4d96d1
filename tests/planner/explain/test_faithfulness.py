"""Explanations a person can check: they point at the decision and are faithful to it."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

from manigraph_lab.episode_loop import run_episode
from manigraph_lab.faithfulness_study import decisions_of, measure, table
from manigraph_planner.explain import ExplainerConfig, SceneExplainer
from manigraph_planner.explain.config import Objective
from manigraph_planner.policies.gnn import GNNPolicy
from manigraph_shared.errors import ConfigError
from manigraph_shared.messages import EpisodeRequest

CHECKPOINTS = Path(__file__).resolve().parents[3] / "checkpoints"
ARCHS = ("gcn", "sage", "gated", "gat")


def test_the_default_objective_is_the_pair_centred_one_and_bad_names_are_refused() -> None:
    assert ExplainerConfig().objective is Objective.PAIR_CONTEXT
    assert ExplainerConfig(objective="distribution").objective is Objective.DISTRIBUTION  # type: ignore[arg-type]
    with pytest.raises(ConfigError, match="objective: must be one of distribution, pair"):
        ExplainerConfig(objective="whole")  # type: ignore[arg-type]


@pytest.mark.parametrize("arch", ARCHS)
def test_the_last_decision_of_a_9_block_stack_is_explained_by_its_own_relations(
    arch: str,
) -> None:
    # The case: block_0 -> goal_8 was explained by block_3->goal_0, block_4->block_1 and
    # block_5->block_4, none touching the decision.
    policy = GNNPolicy.from_checkpoint(CHECKPOINTS / f"{arch}.pt")
    record = run_episode(policy, EpisodeRequest(episode_id="s", task="stack", blocks=9, seed=0))
    last = record.steps[-1]
    assert (last.action.object_id, last.action.goal_id) == ("block_0", "goal_8")
    explanation = SceneExplainer(policy).explain(last.scene, "block_0", "goal_8")
    assert explanation.edges
    assert all({"block_0", "goal_8"} & {e.src, e.dst} for e in explanation.edges)
    assert explanation.sentence.startswith("block_0 was chosen rather than block_")
    assert "(for goal goal_8 rather than goal_" in explanation.sentence
    relations = explanation.sentence.split("because of the relation")[1].split(";")[0]
    assert "block_0" in relations or "goal_8" in relations
    # Features are reasons only with values that differ (never "block_0 1 vs block_8 1")
    compared = re.findall(r"\S+ (\S+) vs \S+ ([^,;)\s]+)", explanation.sentence)
    assert all(mine != theirs for mine, theirs in compared), explanation.sentence
    if "most important feature: " in explanation.sentence:
        named = explanation.sentence.split("most important feature: ")[1].split(" ")[0]
        assert named in list(explanation.features)[:2], explanation.sentence  # a kept one


def test_pair_centred_explanations_hold_the_decision_and_point_at_it() -> None:
    policy = GNNPolicy.from_checkpoint(CHECKPOINTS / "sage.pt")
    decisions = decisions_of(policy, 6, "multistack", 3, 3)
    scores, _ = measure(policy, decisions, ExplainerConfig())
    assert len(scores) == 6
    assert all(s.top_edge_touches for s in scores)  # shown edges touch the chosen pair
    assert sum(s.kept for s in scores) >= 5  # fid- <= 1/6 on the explanation's soft masks
    assert sum(s.lost for s in scores) >= 5  # fid+ >= 5/6: the choice falls without it
    old, _ = measure(policy, decisions, ExplainerConfig(objective=Objective.DISTRIBUTION))
    assert sum(s.top_edge_touches for s in scores) >= sum(s.top_edge_touches for s in old)


def test_the_faithfulness_table_has_a_row_per_task_policy_and_objective() -> None:
    from manigraph_lab.faithfulness_study import run

    cells = run({"sage": CHECKPOINTS / "sage.pt"}, 1, ("distribution", "pair-context"), None)
    text = table(cells)
    assert len(cells) == 6 and text.count("\n| ") == 6
    assert "| 9-block stack | sage | pair-context | 1 |" in text
