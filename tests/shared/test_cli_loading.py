"""The ``manigraph`` command loads only the subcommand it runs: a router or a sim process must
not pay for importing torch because the planner happens to be installed beside it."""

from __future__ import annotations

import json
import subprocess
import sys

import pytest

PROBE = """
import json, sys
from manigraph_shared.cli import build_parser
parser = build_parser({argv!r})
names = sorted(parser._subparsers._group_actions[0].choices)
print(json.dumps([names, 'torch' in sys.modules]))
"""


def _probe(argv: list[str] | None) -> tuple[list[str], bool]:
    result = subprocess.run(
        [sys.executable, "-c", PROBE.format(argv=argv)],
        capture_output=True,
        text=True,
        check=True,
        timeout=300,
    )
    names, torch_loaded = json.loads(result.stdout.strip().splitlines()[-1])
    return names, torch_loaded


@pytest.mark.parametrize("argv", [["router"], ["--log-level", "DEBUG", "router", "--help"]])
def test_a_named_subcommand_loads_alone_and_without_torch(argv: list[str]) -> None:
    names, torch_loaded = _probe(argv)
    assert names == ["router"]
    assert not torch_loaded


def test_an_unknown_subcommand_still_lists_every_installed_one() -> None:
    names, _ = _probe(["nosuch"])  # argparse then names every choice in its error
    assert {"router", "sim", "planner", "skills", "up", "train"} <= set(names)
