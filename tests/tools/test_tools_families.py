"""The episode commands size a family's episodes its own way only through their family
registry (``manigraph_tools.family``), filled from the installed packages' ``tools`` parts."""

from __future__ import annotations

import pytest

from manigraph_shared.errors import ConfigError
from manigraph_tools.episode_plan import EpisodeOptions, summarize
from manigraph_tools.family import FAMILIES, ToolsFamily, family_of_task, register_family


def test_the_installed_dishwasher_sizes_its_episodes_by_dishes_and_preference() -> None:
    assert "dishwasher" in FAMILIES
    family = family_of_task("dishwasher")
    assert family is not None and family.name == "dishwasher"
    assert family.sized_by == ("objects", "preference") and family.counted == "dishes"


def test_a_task_no_family_claims_is_sized_by_blocks_and_stacks() -> None:
    assert family_of_task("stack") is None and family_of_task("file") is None
    summary = summarize(EpisodeOptions(task="stack", blocks=5).plan(1), [])
    assert (summary["blocks"], summary["stacks"]) == (5, 1) and "objects" not in summary


def test_a_family_without_sizes_is_refused_naming_it() -> None:
    with pytest.raises(ConfigError, match=r"family\.empty"):
        register_family(ToolsFamily(name="empty", tasks=("empty",), sized_by=(), counted=""))
    assert "empty" not in FAMILIES
