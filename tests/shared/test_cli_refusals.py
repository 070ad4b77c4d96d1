"""Refusals of the ``manigraph`` command: one line each, and the exit status of their kind
(usage 2, configuration 78, runtime 1: ``manigraph_shared.errors``), through the real CLI
with real files."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

from manigraph_shared.cli import main, one_line
from manigraph_shared.errors import (
    CONFIG_EXIT_CODE,
    RUNTIME_EXIT_CODE,
    USAGE_EXIT_CODE,
    BusError,
    ConfigError,
    LogError,
    ManigraphError,
    PolicyError,
    RequestRefused,
    SkillError,
    TaskError,
)

REPO = Path(__file__).resolve().parents[2]


def _refusal(argv: list[str], capsys: pytest.CaptureFixture[str]) -> tuple[int, list[str]]:
    code = main(argv)
    return code, capsys.readouterr().err.strip().splitlines()


@pytest.mark.parametrize("blocks", ["0", "200"])
def test_blocks_out_of_range_is_a_configuration_error_either_way(
    blocks: str, capsys: pytest.CaptureFixture[str]
) -> None:
    code, lines = _refusal(["eval", "--blocks", blocks, "--episodes", "1"], capsys)
    assert code == CONFIG_EXIT_CODE
    assert len(lines) == 1 and lines[0].startswith("manigraph eval: blocks: "), lines


@pytest.mark.parametrize("blocks", ["0", "200"])
def test_demos_with_blocks_out_of_range_is_a_configuration_error(
    blocks: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    code, lines = _refusal(["demos", "--blocks", blocks, "-o", str(tmp_path / "d.mcap")], capsys)
    assert code == CONFIG_EXIT_CODE
    assert len(lines) == 1 and lines[0].startswith("manigraph demos: blocks: "), lines


def test_a_text_file_given_to_train_is_not_an_mcap_file(
    monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    monkeypatch.chdir(REPO)
    code, lines = _refusal(["train", "README.md"], capsys)
    assert code == CONFIG_EXIT_CODE
    assert lines == ["manigraph train: not an MCAP file: README.md"]


def test_a_text_file_given_as_a_checkpoint_is_not_a_manigraph_checkpoint(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    notes = tmp_path / "notes.pt"
    notes.write_text("e\n")  # torch.load alone says: KeyError: 101
    code, lines = _refusal(["eval", "--policy", str(notes), "--episodes", "1"], capsys)
    assert code == CONFIG_EXIT_CODE
    assert lines == [
        f"manigraph eval: not a manigraph checkpoint: {notes}: a text file, not an archive "
        "torch.save writes"
    ]


@pytest.mark.parametrize(
    "argv",
    [
        ["eval", "--bogus"],
        ["demos", "--bogus"],
        ["train", "data.mcap", "--bogus"],
        ["--log-level", "INFO", "suite", "--bogus"],
        ["calibrate", "intrinsics", "a.png", "-o", "c.yaml", "--bogus"],
    ],
    ids=["eval", "demos", "train", "after-log-level", "nested"],
)
def test_an_unknown_flag_prints_the_subcommands_usage(
    argv: list[str], capsys: pytest.CaptureFixture[str]
) -> None:
    command = " ".join(a for a in argv if a in ("eval", "demos", "train", "suite", "calibrate"))
    command += " intrinsics" if "intrinsics" in argv else ""
    with pytest.raises(SystemExit) as done:
        main(argv)
    assert done.value.code == USAGE_EXIT_CODE
    err = capsys.readouterr().err
    assert err.startswith(f"usage: manigraph {command} ")
    assert err.strip().splitlines()[-1] == (
        f"manigraph {command}: error: unrecognized arguments: --bogus"
    )


def test_a_bad_flag_value_is_a_usage_error(capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(SystemExit) as done:
        main(["eval", "--blocks", "three"])
    assert done.value.code == USAGE_EXIT_CODE
    assert "usage: manigraph eval " in capsys.readouterr().err


def test_the_exit_status_of_each_kind_of_error() -> None:
    configuration = [
        ConfigError("blocks", "must be >= 1"),
        TaskError("blocks: must be in 1..64"),
        PolicyError("not a manigraph checkpoint: x.pt: a text file"),
        LogError("not an MCAP file: x"),
        RequestRefused("manigraph/world/reset: blocks: must be in 1..64"),
    ]
    runtime = [ManigraphError("the stack stopped"), BusError("no answer"), SkillError("x")]
    assert [e.exit_code for e in configuration] == [CONFIG_EXIT_CODE] * len(configuration)
    assert [e.exit_code for e in runtime] == [RUNTIME_EXIT_CODE] * len(runtime)


def test_one_line_joins_a_message_of_several_lines() -> None:
    assert one_line(ValueError("first\n  second\n\nthird")) == "first second third"
    assert one_line(KeyError()) == "KeyError"


def test_an_internal_error_is_one_line_and_a_runtime_failure(tmp_path: Path) -> None:
    # A subcommand whose run raises what no manigraph code names: a bug.
    probe = (
        "import sys, argparse\n"
        "from manigraph_shared import cli\n"
        "def boom(args):\n"
        "    raise KeyError(101)\n"
        "cli.build_parser = lambda argv=None: _parser()\n"
        "def _parser():\n"
        "    p = argparse.ArgumentParser(prog='manigraph')\n"
        "    p.add_argument('--log-level')\n"
        "    s = p.add_subparsers(dest='command', required=True)\n"
        "    s.add_parser('boom').set_defaults(run=boom)\n"
        "    return p\n"
        "sys.exit(cli.main(sys.argv[1:]))\n"
    )
    quiet = subprocess.run(
        [sys.executable, "-c", probe, "boom"], capture_output=True, text=True, timeout=120
    )
    assert quiet.returncode == RUNTIME_EXIT_CODE
    assert quiet.stderr.strip().splitlines() == [
        "manigraph boom: internal error: KeyError: 101 (--log-level DEBUG shows where)"
    ]
    loud = subprocess.run(
        [sys.executable, "-c", probe, "--log-level", "DEBUG", "boom"],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert loud.returncode != 0 and "Traceback" in loud.stderr


def test_select_refuses_a_file_that_is_no_checkpoint_before_any_cell(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    notes = tmp_path / "notes.pt"
    notes.write_text("# notes\n")
    code, lines = _refusal(["select", str(notes), "-o", str(tmp_path / "kept.pt")], capsys)
    assert code == CONFIG_EXIT_CODE
    assert len(lines) == 1 and lines[0].startswith(
        f"manigraph select: not a manigraph checkpoint: {notes}: "
    )


def test_an_output_path_that_cannot_be_written_is_one_line(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    blocker = tmp_path / "a-file"
    blocker.write_text("")
    target = blocker / "demos.mcap"  # under a file, not a folder
    code, lines = _refusal(["demos", "-o", str(target), "--trajectories", "1"], capsys)
    assert code == CONFIG_EXIT_CODE
    assert len(lines) == 1 and lines[0].startswith("manigraph demos: "), lines
    assert str(blocker) in lines[0] and "internal error" not in lines[0]


def test_a_stop_signal_exits_as_a_shell_reports_it() -> None:
    from manigraph_shared.cli import interrupted_exit_code
    from manigraph_shared.errors import INTERRUPTED_EXIT_CODE

    assert interrupted_exit_code(KeyboardInterrupt()) == INTERRUPTED_EXIT_CODE == 130
    assert interrupted_exit_code(KeyboardInterrupt("SIGINT")) == 130
    assert interrupted_exit_code(KeyboardInterrupt("SIGTERM")) == 143  # up stopped by kill
    assert interrupted_exit_code(KeyboardInterrupt("SIGHUP")) == 129  # its terminal closed
    assert interrupted_exit_code(KeyboardInterrupt("something else")) == 130
