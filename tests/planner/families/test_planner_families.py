"""Each task family declares its planner part in one place (its package's ``planner``), and the
generic layers reach them only through the registries: heads, networks, policies, experts."""

from __future__ import annotations

from pathlib import Path

import pytest

from manigraph_blocks.planner.expert import ExpertPolicy
from manigraph_dishwasher.planner.expert import LeftRightExpert, TopBottomExpert
from manigraph_dishwasher.planner.features import DISH_FEATURE_SPEC
from manigraph_dishwasher.planner.gnn_policy import DishwasherGNNPolicy
from manigraph_dishwasher.planner.net import DishPolicyNet
from manigraph_dishwasher.training.train_command import train_from_args
from manigraph_planner.family import FAMILIES, family_for_heads, family_of
from manigraph_planner.gnn.features import FEATURE_SPEC
from manigraph_planner.gnn.models import ModelConfig, PolicyNet
from manigraph_planner.gnn.models.build import policy_net_for
from manigraph_planner.gnn.models.config import HEADS, feature_spec_for
from manigraph_planner.policies import POLICIES, load_policy
from manigraph_planner.policies.gnn import GNNPolicy
from manigraph_shared.errors import CONFIG_EXIT_CODE, ConfigError
from manigraph_shared.messages import EpisodeRequest, Scene
from manigraph_sim.geometric.backend import GeometricBackend
from manigraph_testkit.families import families_with

REPO = Path(__file__).resolve().parents[3]


def first_scene(task: str, **request: int) -> Scene:
    backend = GeometricBackend()
    backend.reset(EpisodeRequest(episode_id="e", task=task, **request), 0.0)
    return backend.scene(1.0)


def test_each_family_registers_its_heads_feature_spec_and_experts() -> None:
    assert list(FAMILIES) == families_with("planner")
    blocks, dishwasher = FAMILIES["blocks"], FAMILIES["dishwasher"]
    assert (blocks.heads, dishwasher.heads) == ("object-goal", "dishwasher")
    assert set(HEADS) == {"object-goal", "dishwasher"}
    assert feature_spec_for("object-goal") is FEATURE_SPEC
    assert feature_spec_for("dishwasher") is DISH_FEATURE_SPEC
    assert POLICIES["expert"] is ExpertPolicy and blocks.experts == ("expert",)
    assert [POLICIES[name] for name in dishwasher.experts] == [TopBottomExpert, LeftRightExpert]
    # the dishwasher trains by its own command; blocks by the generic trainer, with its recipes
    assert dishwasher.part("recipe") is None
    assert dishwasher.part("train_command") is train_from_args
    assert "sage" in blocks.part("recipe") and blocks.part("train_command") is None


def test_the_scene_says_its_family_and_the_heads_say_the_network() -> None:
    assert family_of(first_scene("stack", blocks=3)).name == "blocks"
    assert family_of(first_scene("dishwasher", objects=4)).name == "dishwasher"
    block_net = policy_net_for(ModelConfig("sage", hidden_channels=8))
    dish_net = policy_net_for(ModelConfig("sage", hidden_channels=8, heads="dishwasher"))
    assert type(block_net) is PolicyNet and isinstance(dish_net, DishPolicyNet)
    with pytest.raises(ConfigError, match="heads"):
        family_for_heads("three-headed")
    with pytest.raises(ConfigError, match="only 'dishwasher' heads have members"):
        ModelConfig("sage", ensemble=2)


@pytest.mark.parametrize(
    ("name", "family", "policy"),
    [
        ("sage.pt", "blocks", GNNPolicy),
        ("gat.pt", "blocks", GNNPolicy),
        ("dishwasher-top-bottom-sage.pt", "dishwasher", DishwasherGNNPolicy),
        ("dishwasher-left-right-sage.pt", "dishwasher", DishwasherGNNPolicy),
    ],
)
def test_shipped_checkpoints_load_through_their_familys_registration(
    name: str, family: str, policy: type
) -> None:
    if family == "dishwasher":
        scene = first_scene("dishwasher", objects=4)
    else:
        scene = first_scene("stack", blocks=3)
    loaded = load_policy(str(REPO / "checkpoints" / name))
    assert loaded.decide(scene) is not None
    assert type(loaded) is policy
    assert family_for_heads(loaded.net.config.heads).name == family  # type: ignore[attr-defined]
    assert family_of(scene).name == family


def test_train_runs_the_family_s_own_command_for_its_heads(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """``--heads dishwasher`` reaches the dishwasher's own training command (it trains on the
    CPU only and says so before reading any log)."""
    from manigraph_shared.cli import main

    log = str(tmp_path / "demos.mcap")
    assert main(["train", log, "--heads", "dishwasher", "--device", "cuda"]) == CONFIG_EXIT_CODE
    assert "the dishwasher recipe trains on the CPU only" in capsys.readouterr().err
