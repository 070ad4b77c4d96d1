"""Every flag of every installed subcommand is described in its ``--help``, and each
subcommand's help speaks of that subcommand."""

from __future__ import annotations

import argparse
from collections.abc import Iterator

import pytest

from manigraph_shared.cli import build_parser, main, subcommand_parsers


def _parsers(
    parser: argparse.ArgumentParser, name: str
) -> Iterator[tuple[str, argparse.ArgumentParser]]:
    """``parser`` and, depth first, every subcommand parser under it (``calibrate
    intrinsics``)."""
    yield name, parser
    for child_name, child in subcommand_parsers(parser).items():
        yield from _parsers(child, f"{name} {child_name}")


def test_every_option_of_every_subcommand_has_a_help_text() -> None:
    top = build_parser()
    commands = subcommand_parsers(top)
    assert {"up", "run", "eval", "demos", "train", "suite", "select"} <= set(commands)
    undescribed = [
        f"manigraph {where}: {'/'.join(action.option_strings) or action.dest}"
        for name, command in sorted(commands.items())
        for where, parser in _parsers(command, name)
        for action in parser._actions
        if not isinstance(action, argparse._HelpAction)
        and (not (action.help or "").strip() or action.help == argparse.SUPPRESS)
    ]
    assert undescribed == []


def test_demos_help_describes_each_flag(capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(SystemExit) as done:
        main(["demos", "--help"])
    assert done.value.code == 0
    text = capsys.readouterr().out
    for words in ("MCAP log to write", "tasks to demonstrate", "block counts", "demonstrations in"):
        assert words in text


def test_eval_help_speaks_of_eval_not_of_up(capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(SystemExit):
        main(["eval", "--help"])
    text = capsys.readouterr().out
    assert "episodes to play" in text
    assert "stack running" not in text and "up without it" not in text
    # Every episode runs to its end in one process: no timeouts to set.
    assert "--stall-timeout" not in text and "--timeout" not in text
