"""The per-architecture training recipes, registered by architecture name."""

from __future__ import annotations

import pytest

from manigraph_blocks.training.recipes import GATED_MAX_LEVELS, RECIPES
from manigraph_planner.gnn.models import ARCHITECTURES
from manigraph_shared.errors import ConfigError
from manigraph_training.recipes import augmentation_for, recipes, resample_every_for
from manigraph_training.trainer import TrainConfig


def test_every_architecture_has_a_recipe() -> None:
    assert list(RECIPES) and set(RECIPES) == set(ARCHITECTURES)


def test_the_generic_trainer_draws_with_the_recipes_the_block_family_names() -> None:
    assert recipes() is RECIPES


def test_each_recipe_is_its_architectures() -> None:
    gcn = augmentation_for("gcn")
    assert (gcn.copies, gcn.noise_xy, gcn.tower_probability) == (8, 0.004, 0.0)
    assert gcn.drop_covers_probability > 0 and resample_every_for("gcn") == 0
    assert gcn.drop_finished_probability == 0.0  # measured mixed: docs/training.md
    assert augmentation_for("gated").max_levels == GATED_MAX_LEVELS
    assert augmentation_for("gat").open_box_contents_probability == 0.0
    assert augmentation_for("sage").open_box_contents_probability > 0
    assert augmentation_for("sage").copies == 16 and resample_every_for("sage") == 10
    assert augmentation_for("gcn", copies=3).copies == 3


def test_bad_recipe_options_and_unknown_architectures_are_named() -> None:
    with pytest.raises(ConfigError, match=r"recipe\.copies: must be >= 1, got 0"):
        augmentation_for("sage", copies=0)
    with pytest.raises(ConfigError, match="architecture: 'transformer' is not one of"):
        TrainConfig(architecture="transformer")
    assert TrainConfig(architecture="gcn").resample_every == 0
