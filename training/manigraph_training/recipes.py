"""The generic trainer's augmentation, by architecture: drawn from the recipes of the family
whose heads it trains (``object-goal``: ``PlannerFamily.recipe``, the block family's).

A recipe registry maps an architecture to ``(options) -> Augmenter``, each with its options
(copies per sample, epochs between fresh draws); ``manigraph train --copies/--resample-every``
override them. ``TrainConfig`` refuses an architecture without a recipe."""

from __future__ import annotations

from collections.abc import Callable
from typing import TYPE_CHECKING, Any, Protocol

from manigraph_planner.family import family_for_heads
from manigraph_shared.errors import ConfigError
from manigraph_shared.registry import Registry

if TYPE_CHECKING:
    import torch

    from manigraph_planner.gnn.features import FeatureSpec
    from manigraph_training.dataset import Sample

__all__ = ["GENERIC_HEADS", "Augmenter", "augmentation_for", "recipes", "resample_every_for"]

#: The heads the generic trainer trains (the paper's object and goal logits).
GENERIC_HEADS = "object-goal"


class Augmenter(Protocol):
    """What the generic trainer asks of a family's augmentation."""

    def for_task(self, spec: FeatureSpec | None = None) -> Augmenter:
        """This augmentation for demonstrations with ``spec``'s columns."""
        ...

    def apply(self, samples: list[Sample], generator: torch.Generator) -> list[Sample]:
        """One augmented draw of ``samples``."""
        ...

    def grown(self, pairs: int) -> Augmenter:
        """This augmentation adding up to ``pairs`` copies of pairs (``train --grow``)."""
        ...


def recipes() -> Registry[Callable[[Any], Augmenter]]:
    """The recipes of the family with the generic trainer's heads."""
    family = family_for_heads(GENERIC_HEADS)
    found = family.part("recipe")
    if not isinstance(found, Registry):
        raise ConfigError("recipe", f"the {family.name} family names no augmentation recipes")
    return found


def augmentation_for(architecture: str, copies: int | None = None) -> Augmenter:
    """The augmentation of ``architecture``'s recipe, with ``copies`` per sample (default:
    the recipe's)."""
    registry = recipes()
    options = registry.options(architecture, {} if copies is None else {"copies": copies})
    return registry[architecture](options)


def resample_every_for(architecture: str) -> int:
    """Epochs between fresh draws of augmented copies in ``architecture``'s recipe."""
    return int(recipes().options(architecture).resample_every)
