"""The dishwasher family's part of the episode commands: its episodes are sized by their
dishes and the loading preference, not blocks and stacks (``manigraph_tools.family``)."""

from collections.abc import Mapping
from typing import Any

from manigraph_dishwasher.fixtures import RACK, TOGGLE
from manigraph_dishwasher.preference import expert_name
from manigraph_tools.family import ToolsFamily


def _expert_of(options: Mapping[str, Any]) -> str:
    return expert_name(options.get("preference"))


#: This family's tools part (its package's ``manigraph.families`` entry names it).
FAMILY = ToolsFamily(
    name="dishwasher",
    tasks=("dishwasher",),
    sized_by=("objects", "preference"),
    counted="dishes",
    expert_of=_expert_of,
    help="episodes sized by their dishes and the preference",
    fixture_actions={RACK: TOGGLE},
)
