"""The dishwasher family's part of the episode commands: its episodes are sized by their
dishes and the loading preference, not blocks and stacks (``manigraph_tools.family``)."""

from manigraph_tools.family import ToolsFamily

#: This family's tools part (its package's ``manigraph.families`` entry names it).
FAMILY = ToolsFamily(
    name="dishwasher",
    tasks=("dishwasher",),
    sized_by=("objects", "preference"),
    counted="dishes",
    help="episodes sized by their dishes and the preference",
)
