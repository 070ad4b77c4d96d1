"""Each task family's planner registration says which of its experts demonstrates a request."""

from __future__ import annotations

import pytest

from manigraph_blocks.planner.expert import ExpertPolicy
from manigraph_dishwasher.planner.expert import LeftRightExpert, TopBottomExpert
from manigraph_planner.family import FAMILIES
from manigraph_planner.policies import POLICIES
from manigraph_shared.errors import ConfigError
from manigraph_shared.messages import EpisodeRequest


def request(task: str, **fields: object) -> EpisodeRequest:
    return EpisodeRequest(episode_id="e", task=task, **fields)


def test_the_block_family_demonstrates_with_expert() -> None:
    assert type(FAMILIES["blocks"].expert(request("stack", blocks=3))) is ExpertPolicy


def test_the_dishwasher_demonstrates_with_the_expert_of_the_request_s_preference() -> None:
    dishwasher = FAMILIES["dishwasher"]
    assert type(dishwasher.expert(request("dishwasher"))) is TopBottomExpert  # the sim's default
    assert type(dishwasher.expert(request("dishwasher", options={"preference": "top-bottom"}))) is (
        TopBottomExpert
    )
    assert type(dishwasher.expert(request("dishwasher", options={"preference": "left-right"}))) is (
        LeftRightExpert
    )


def test_every_family_expert_is_a_policy_under_its_own_name() -> None:
    for _, family in FAMILIES.items():
        for name in family.experts:
            assert POLICIES[name].name == name  # ``--policy <its name>`` serves it


def test_a_family_naming_an_expert_it_does_not_register_is_refused() -> None:
    from dataclasses import replace

    wrong = replace(FAMILIES["blocks"], expert_of=lambda _: "dishwasher-top-bottom")
    with pytest.raises(ConfigError, match="not one of the blocks experts"):
        wrong.expert(request("stack"))
