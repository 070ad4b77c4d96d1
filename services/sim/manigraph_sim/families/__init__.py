"""Task families: each one registered unit, in one folder (``docs/architecture.md``, "Task
families"). A new family: a folder like ``blocks/``, and one line here."""

from manigraph_sim.families.base import FAMILIES, Evaluation, SimFamily, family_of, register_family
from manigraph_sim.families.blocks.family import BlocksFamily
from manigraph_sim.families.dishwasher.family import DishwasherFamily

register_family(BlocksFamily)
register_family(DishwasherFamily)

__all__ = ["FAMILIES", "Evaluation", "SimFamily", "family_of", "register_family"]
