"""docs/running.md stays true to the code: it names every registered task (a family package's
own, there or in its package's README.md), and its exit-code table holds the codes
``manigraph_shared.errors`` defines."""

from __future__ import annotations

import re
from pathlib import Path

from manigraph_shared import errors

REPO = Path(__file__).resolve().parents[2]
RUNNING = REPO / "docs" / "running.md"


def _section(title: str) -> str:
    text = RUNNING.read_text()
    start = text.index(f"## {title}\n")
    end = text.find("\n## ", start + 1)
    return text[start : end if end >= 0 else None]


def _named(text: str) -> set[str]:
    return set(re.findall(r"`([a-z][a-z-]*)`", text))


def test_every_registered_task_is_listed() -> None:
    from manigraph_sim.family import FAMILIES
    from manigraph_sim.tasks import TASKS

    listed = _named(_section("Tasks and task files").split("* **Your own layouts**")[0])
    for name, family in FAMILIES.items():
        readme = REPO / "families" / name / "README.md"
        if readme.is_file():
            listed |= _named(readme.read_text()) & set(family.tasks)
    assert set(TASKS) - listed == set()


def test_the_exit_code_table_holds_every_kind() -> None:
    rows = {
        int(match.group(1)): match.group(2)
        for match in re.finditer(r"^\| (\d+) \| ([a-z]+) \|", _section("Exit codes"), re.M)
    }
    assert rows == {
        0: "success",
        errors.RUNTIME_EXIT_CODE: "runtime",
        errors.USAGE_EXIT_CODE: "usage",
        errors.CONFIG_EXIT_CODE: "configuration",
        errors.INTERRUPTED_EXIT_CODE: "interrupted",
    }
