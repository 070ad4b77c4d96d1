"""Family packages declare themselves by one ``manigraph.families`` entry point, and each
service's registry registers their parts once, when first read, in the families' name order.
The extra families here are real installed distributions: a ``.dist-info`` folder on the
path of a fresh interpreter."""

from __future__ import annotations

import os
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

from manigraph_shared.errors import ConfigError
from manigraph_shared.registry import Registry
from manigraph_testkit.families import families_with


def install(site: Path, name: str, declaration: str, module: str = "") -> None:
    """A distribution ``name`` in ``site`` declaring ``declaration`` in the group, with the
    module ``<name>_family.py`` holding ``module``."""
    info = site / f"{name}_family-0.1.dist-info"
    info.mkdir(parents=True)
    (info / "METADATA").write_text(f"Metadata-Version: 2.1\nName: {name}-family\nVersion: 0.1\n")
    (info / "entry_points.txt").write_text(f"[manigraph.families]\n{declaration}\n")
    if module:
        (site / f"{name}_family.py").write_text(textwrap.dedent(module))


def run(site: Path, code: str) -> subprocess.CompletedProcess[str]:
    environment = {**os.environ, "PYTHONPATH": str(site)}
    return subprocess.run(
        [sys.executable, "-c", textwrap.dedent(code)],
        capture_output=True,
        text=True,
        timeout=120,
        env=environment,
    )


SKILLS_PART = """
from manigraph_skills.family import SkillFamily
PARTS = {{"skills": "{name}_family:FAMILY"}}
FAMILY = SkillFamily(name="{name}", fallback={fallback}, matches=lambda scene: False)
"""


def test_families_register_in_name_order_and_only_where_they_have_a_part(
    tmp_path: Path,
) -> None:
    install(
        tmp_path,
        "aardvark",
        "aardvark = aardvark_family:PARTS",
        SKILLS_PART.format(name="aardvark", fallback=False),
    )
    result = run(
        tmp_path,
        """
        from manigraph_skills.family import FAMILIES as SKILLS
        from manigraph_sim.family import FAMILIES as SIM
        print(SKILLS.names(), SIM.names())
        """,
    )
    assert result.returncode == 0, result.stderr[-2000:]
    skills, sim = families_with("skills"), families_with("sim")
    assert {"blocks", "dishwasher"} <= set(sim) and "aardvark" not in skills
    assert result.stdout.strip() == f"{['aardvark', *skills]} {sim}"


def test_a_second_fallback_family_is_refused_naming_the_first(tmp_path: Path) -> None:
    install(
        tmp_path, "zeta", "zeta = zeta_family:PARTS", SKILLS_PART.format(name="zeta", fallback=True)
    )
    result = run(tmp_path, "from manigraph_skills.family import FAMILIES; FAMILIES.names()")
    assert result.returncode != 0
    assert "'zeta': 'blocks' is the fallback already" in result.stderr


def test_a_family_declared_twice_is_refused(tmp_path: Path) -> None:
    install(tmp_path, "twin", "blocks = manigraph_blocks:PARTS")
    result = run(tmp_path, "from manigraph_sim.family import FAMILIES; FAMILIES.names()")
    assert result.returncode != 0
    assert "family: declared by two packages: blocks" in result.stderr


def test_a_declaration_that_is_not_parts_is_refused_naming_the_family(tmp_path: Path) -> None:
    install(tmp_path, "broken", "broken = broken_family:PARTS", 'PARTS = ["sim"]\n')
    result = run(tmp_path, "from manigraph_planner.family import FAMILIES; FAMILIES.names()")
    assert result.returncode != 0
    assert "family.broken: broken_family:PARTS is not a dict of 'module:attribute'" in (
        result.stderr
    )


def test_a_registry_fills_once_before_its_first_read_and_reads_inside_do_not_refill() -> None:
    calls: list[list[str]] = []

    def fill() -> None:
        registry.add("filled", 2)
        calls.append(registry.names())  # a read while filling sees what is there so far

    registry: Registry[int] = Registry("thing", fill=fill)
    registry.add("own", 1)
    later: list[str] = []
    registry.fill_with(lambda: later.append("then"))
    assert calls == [] and later == []  # registering reads nothing
    assert registry.names() == ["own", "filled"] and registry["filled"] == 2
    assert "own" in registry and len(registry) == 2
    assert calls == [["own", "filled"]] and later == ["then"]
    with pytest.raises(ConfigError, match="'missing' is not one of: own, filled"):
        registry.check("missing")
