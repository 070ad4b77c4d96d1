"""The task families' skill extensions, one folder each, registered in :data:`FAMILIES`
(:mod:`.family`). A new family is a folder whose ``__init__`` registers its
:class:`SkillFamily`, and one import line here."""

from manigraph_skills.families import blocks, dishwasher  # noqa: F401  (register)
from manigraph_skills.families.family import (
    FAMILIES,
    SkillFamily,
    families,
    family_of,
    family_taking,
    register_family,
)

__all__ = [
    "FAMILIES",
    "SkillFamily",
    "families",
    "family_of",
    "family_taking",
    "register_family",
]
