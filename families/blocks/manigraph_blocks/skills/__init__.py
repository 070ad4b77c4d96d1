"""The block family's skill extensions: the walls of the boxes its covers close
(:mod:`.obstacles`). Blocks are set down at their goal's point and follow no rule beyond the
goal's own; it is the fallback family (a scene no other family claims)."""

from manigraph_skills.family import SkillFamily

#: This family's skills part (its package's ``manigraph.families`` entry names it).
FAMILY = SkillFamily(
    name="blocks",
    fallback=True,
    obstacles="manigraph_blocks.skills.obstacles:box_walls",
    help="blocks, covers and boxes: the boxes' walls as obstacles",
)
