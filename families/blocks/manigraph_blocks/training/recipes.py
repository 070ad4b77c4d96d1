"""The per-architecture training recipes: which augmentation, how many copies, how often drawn.

Registered by architecture name in :data:`RECIPES` (the block family's ``PlannerFamily.recipe``,
which the generic trainer draws with: ``manigraph_training.recipes``), each with its
options (copies per sample, epochs between fresh draws) whose defaults are that
architecture's; ``manigraph train --copies/--resample-every`` override them. Why each
recipe is what it is: the module docstring of :mod:`~manigraph_blocks.training.augment`. A new
architecture registers its recipe here too (``TrainConfig`` refuses an architecture without one)::

    @RECIPES.register("mine", options=RecipeOptions, help="every step")
    def _mine(options: RecipeOptions) -> Augmentation:
        return Augmentation(copies=options.copies)
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, replace

from manigraph_blocks.training.augment import Augmentation
from manigraph_shared.options import Interval, Options, option
from manigraph_shared.registry import Registry

__all__ = [
    "GATED_MAX_LEVELS",
    "RECIPES",
    "RecipeOptions",
    "TranslationRecipeOptions",
]

#: Level cap of the structural steps for ``gated``: see the augment module docstring.
GATED_MAX_LEVELS = 6


@dataclass(frozen=True)
class RecipeOptions(Options):
    """A recipe with the structural steps on: many scenes to show, so fresh draws often."""

    copies: int = option(16, help="augmented copies per sample", within=Interval(1, None))
    resample_every: int = option(
        10, help="draw fresh copies every N epochs (0: once)", within=Interval(0, None)
    )


@dataclass(frozen=True)
class TranslationRecipeOptions(RecipeOptions):
    """Translation and noise only: fewer copies, drawn once (as measured for ``gcn``)."""

    copies: int = option(8, help="augmented copies per sample", within=Interval(1, None))
    resample_every: int = option(
        0, help="draw fresh copies every N epochs (0: once)", within=Interval(0, None)
    )


RECIPES: Registry[Callable[[RecipeOptions], Augmentation]] = Registry("recipe")


@RECIPES.register("gcn", options=TranslationRecipeOptions, help="translation, noise, no covers")
def _gcn(options: RecipeOptions) -> Augmentation:
    translation_and_noise = Augmentation(copies=options.copies, noise_xy=0.004)
    return replace(
        translation_and_noise.without_structure(),
        drop_covers_probability=translation_and_noise.drop_covers_probability,
    )


@RECIPES.register("sage", options=RecipeOptions, help="every step")
def _sage(options: RecipeOptions) -> Augmentation:
    return Augmentation(copies=options.copies)


@RECIPES.register("gated", options=RecipeOptions, help="every step, capped at 6 levels")
def _gated(options: RecipeOptions) -> Augmentation:
    cap = GATED_MAX_LEVELS
    return replace(
        Augmentation(copies=options.copies),
        max_levels=cap,
        max_free_levels=cap,
        max_finished_levels=cap,
    )


@RECIPES.register("gat", options=RecipeOptions, help="every step but open boxes with contents")
def _gat(options: RecipeOptions) -> Augmentation:
    """``gat`` gets no open box with contents (step 4): it already finished box
    rearrangement without it (validation, seeds 1000+: 1.00), and with it K = 40 stacking
    fell (training seed 1: 1.00 without, 0.10 with; seeds 0 and 2 with it: 0.74, 0.00)."""
    return replace(Augmentation(copies=options.copies), open_box_contents_probability=0.0)
