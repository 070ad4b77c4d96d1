"""The shelf family's part of the episode commands: its episodes are sized by their objects
(blocks, one per slot), not blocks and stacks (``manigraph_tools.family``)."""

from manigraph_tools.family import ToolsFamily

#: This family's tools part (its package's ``manigraph.families`` entry names it).
FAMILY = ToolsFamily(
    name="shelf",
    tasks=("shelf",),
    sized_by=("objects",),
    counted="blocks",
    expert_of=lambda options: "shelf-expert",
    help="episodes sized by their blocks (one per slot)",
)
