"""The generic trainer draws its augmentation from the recipes of the family whose
demonstrations it trains, falling back to the first family with its heads that names some
(the block family's) for a family without (shelf) or demonstrations of several."""

from __future__ import annotations

from pathlib import Path

import pytest

from manigraph_blocks.training.recipes import RECIPES
from manigraph_lab.demo_recording import DemoProtocol, record_demos
from manigraph_planner.family import FAMILIES, PlannerFamily
from manigraph_shared.errors import ConfigError
from manigraph_shared.registry import Registry
from manigraph_training.dataset import load_demonstrations
from manigraph_training.recipes import augmentation_for, recipes
from manigraph_training.trainer import TrainConfig

#: A second object-goal family's own recipes (what a family's training part declares).
PLANTED: Registry[object] = Registry("recipe")


def test_a_family_naming_recipes_brings_its_own() -> None:
    planted = PlannerFamily(
        name="planted", heads="object-goal", experts=(), recipe=f"{__name__}:PLANTED"
    )
    assert recipes(planted) is PLANTED


def test_without_recipes_of_its_own_the_fallback_is_the_block_familys() -> None:
    assert recipes() is RECIPES
    assert recipes(FAMILIES["shelf"]) is RECIPES  # object-goal heads, no recipe of its own
    assert augmentation_for("gcn", family="shelf") == augmentation_for("gcn")
    config = TrainConfig(architecture="gcn", family="shelf")
    assert config.to_dict()["family"] == "shelf" and "family" not in TrainConfig().to_dict()
    with pytest.raises(ConfigError, match="family: 'cupboard' is not one of"):
        TrainConfig(family="cupboard")


@pytest.fixture(scope="module")
def logs(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    folder = tmp_path_factory.mktemp("family-demos")
    protocols = {
        "shelf": DemoProtocol(("shelf",), (1,), trajectories=2, seed=53470, objects=4),
        "blocks": DemoProtocol(("stack",), (3,), trajectories=2, seed=53480),
    }
    for name, protocol in protocols.items():
        record_demos(None, protocol, folder / f"{name}.mcap")
    return {name: folder / f"{name}.mcap" for name in protocols}


def test_demonstrations_say_their_family(logs: dict[str, Path]) -> None:
    assert load_demonstrations([logs["shelf"]]).family == "shelf"
    assert load_demonstrations([logs["blocks"]]).family == "blocks"
    assert load_demonstrations(logs.values()).family is None  # several: the fallback's recipe
