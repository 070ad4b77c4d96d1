"""The task families' planner parts, one folder each, registered in :data:`FAMILIES`
(:mod:`.family`). A new family is a folder whose ``__init__`` registers its
:class:`PlannerFamily`, and one import line here."""

# One line per family (dishwasher first: the policies keep the order they had in listings).
from manigraph_planner.families import blocks, dishwasher  # noqa: F401  (register)
from manigraph_planner.families.family import (
    FAMILIES,
    PlannerFamily,
    family_for_heads,
    family_of,
    register_family,
)

__all__ = ["FAMILIES", "PlannerFamily", "family_for_heads", "family_of", "register_family"]
