"""The generic trainer's augmentation, by architecture: drawn from the recipes of the family
whose demonstrations it trains (``PlannerFamily.recipe``), or, for a family that names none
(or demonstrations of several), from those of the first family with the heads it trains
(``object-goal``) that names them: the block family's.

A recipe registry maps an architecture to ``(options) -> Augmenter``, each with its options
(copies per sample, epochs between fresh draws); ``manigraph train --copies/--resample-every``
override them. ``TrainConfig`` refuses an architecture without a recipe."""

from __future__ import annotations

from collections.abc import Callable
from typing import TYPE_CHECKING, Any, Protocol

from manigraph_planner.family import FAMILIES, PlannerFamily
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


def recipes(family: PlannerFamily | None = None) -> Registry[Callable[[Any], Augmenter]]:
    """The recipes for demonstrations of ``family``: its own, else the first family's with
    the generic trainer's heads that names some (``ConfigError`` if none does)."""
    own = None if family is None else family.part("recipe")
    if isinstance(own, Registry):
        return own
    for _, known in FAMILIES.items():
        found = known.part("recipe") if known.heads == GENERIC_HEADS else None
        if isinstance(found, Registry):
            return found
    raise ConfigError("recipe", f"no family with {GENERIC_HEADS} heads names augmentation recipes")


def _recipes_of(family: str | None) -> Registry[Callable[[Any], Augmenter]]:
    """:func:`recipes` for the family named ``family`` (``ConfigError`` naming the known)."""
    return recipes(None if family is None else FAMILIES[family])


def augmentation_for(
    architecture: str, copies: int | None = None, family: str | None = None
) -> Augmenter:
    """The augmentation of ``architecture``'s recipe for demonstrations of ``family`` (None:
    the fallback's), with ``copies`` per sample (default: the recipe's)."""
    registry = _recipes_of(family)
    options = registry.options(architecture, {} if copies is None else {"copies": copies})
    return registry[architecture](options)


def resample_every_for(architecture: str, family: str | None = None) -> int:
    """Epochs between fresh draws of augmented copies in ``architecture``'s recipe for
    demonstrations of ``family`` (None: the fallback's)."""
    return int(_recipes_of(family).options(architecture).resample_every)
