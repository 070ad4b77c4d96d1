"""The task-family packages this repository declares (``families/*/pyproject.toml``), read
from the source tree rather than the installed entry points: a test comparing a registry with
them fails for a family package that is in the repository but not installed or registered, and
needs no edit when a family is added."""

from __future__ import annotations

import tomllib
from pathlib import Path

from manigraph_shared.family_packages import GROUP
from manigraph_shared.registry import import_target

REPO = Path(__file__).resolve().parents[2]


def declared_families(repo: Path = REPO) -> dict[str, set[str]]:
    """Each family package under ``repo/families/``, by family name, with the services its
    ``PARTS`` extend (``sim``, ``planner``, ``skills``, ``tools``)."""
    declared: dict[str, set[str]] = {}
    for pyproject in sorted((repo / "families").glob("*/pyproject.toml")):
        project = tomllib.loads(pyproject.read_text())["project"]
        for name, target in project.get("entry-points", {}).get(GROUP, {}).items():
            declared[name] = set(import_target(target))
    return declared


def families_with(part: str, repo: Path = REPO) -> list[str]:
    """The names of the repository's families with a ``part`` (a service), in name order."""
    return sorted(name for name, parts in declared_families(repo).items() if part in parts)
