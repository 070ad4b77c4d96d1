"""``manigraph eval`` without ``--policy`` plays each episode by its task family's expert, and
sizes its summary as ``up`` does (``ToolsFamily.sized_by``); a named policy is that policy."""

from __future__ import annotations

import json

import pytest

from manigraph_lab.demo_recording import family_experts
from manigraph_shared.cli import main
from manigraph_shared.messages import EpisodeRequest

SEED = ["--seed", "53410", "--episodes", "2", "--json"]


def _eval(argv: list[str], capsys: pytest.CaptureFixture[str]) -> dict[str, object]:
    assert main(["eval", *argv, *SEED]) == 0
    return dict(json.loads(capsys.readouterr().out.strip().splitlines()[-1]))


def test_the_default_is_each_familys_expert_sized_by_its_family(
    capsys: pytest.CaptureFixture[str],
) -> None:
    shelf = _eval(["--task", "shelf", "--objects", "6"], capsys)
    assert (shelf["policy"], shelf["success_rate"], shelf["objects"]) == ("shelf-expert", 1.0, 6)
    assert "blocks" not in shelf and "stacks" not in shelf

    dishes = _eval(["--task", "dishwasher", "--objects", "6", "--preference", "left-right"], capsys)
    assert (dishes["policy"], dishes["success_rate"]) == ("dishwasher-left-right", 1.0)
    assert (dishes["objects"], dishes["preference"]) == (6, "left-right")
    assert "blocks" not in dishes and "stacks" not in dishes


def test_the_block_tasks_keep_their_expert_and_sizes(capsys: pytest.CaptureFixture[str]) -> None:
    stack = _eval(["--task", "stack", "--blocks", "3"], capsys)
    assert (stack["policy"], stack["success_rate"]) == ("expert", 1.0)
    assert (stack["blocks"], stack["stacks"]) == (3, 1) and "objects" not in stack


def test_a_named_policy_plays_every_episode(capsys: pytest.CaptureFixture[str]) -> None:
    argv = ["--task", "dishwasher", "--objects", "6", "--preference", "left-right"]
    named = _eval(["--policy", "dishwasher-top-bottom", *argv], capsys)
    assert named["policy"] == "dishwasher-top-bottom"


def test_one_expert_plays_all_the_episodes_it_is_picked_for() -> None:
    pick = family_experts()
    first, second, shelf = (
        pick(EpisodeRequest(episode_id=f"e{i}", task=task, seed=53410 + i, objects=4))
        for i, task in enumerate(["dishwasher", "dishwasher", "shelf"])
    )
    assert first is second and first.name == "dishwasher-top-bottom"
    assert shelf.name == "shelf-expert"
