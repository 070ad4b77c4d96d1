"""The lab's commands show progress on a terminal and keep ``--json`` output clean."""

from __future__ import annotations

import io
from pathlib import Path

import pytest

from manigraph_shared.cli import main
from manigraph_shared.errors import CONFIG_EXIT_CODE


class Terminal(io.StringIO):
    """A stream that says it is a TTY, as stderr does in a terminal."""

    def isatty(self) -> bool:
        return True


@pytest.mark.parametrize("json_flag", [False, True])
def test_eval_draws_a_bar_on_a_terminal_unless_given_json(
    json_flag: bool, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    stderr = Terminal()
    monkeypatch.setattr("sys.stderr", stderr)
    argv = ["eval", "--task", "stack", "--blocks", "3", "--episodes", "2"]
    assert main(argv + (["--json"] if json_flag else [])) == 0
    out = capsys.readouterr().out
    if json_flag:
        assert stderr.getvalue() == ""
        assert out.strip().startswith("{")
    else:
        assert "eval expert stack K=3" in stderr.getvalue() and "2/2" in stderr.getvalue()
        assert "success_rate" in out


def test_demos_and_train_draw_bars_on_a_terminal_and_nothing_in_a_pipe(
    tmp_path: Path,
    monkeypatch: pytest.MonkeyPatch,
    capsys: pytest.CaptureFixture[str],
) -> None:
    demos, checkpoint = tmp_path / "demos.mcap", tmp_path / "gcn.pt"
    demos_argv = ["demos", "-o", str(demos), "--trajectories", "2", "--blocks", "3"]
    train_argv = ["train", str(demos), "--arch", "gcn", "--epochs", "2", "-o", str(checkpoint)]

    assert main(demos_argv) == 0 and main(train_argv) == 0  # stderr captured: not a TTY
    captured = capsys.readouterr()
    assert captured.err == ""
    assert [line[0] for line in captured.out.splitlines()] == ["{", "{"]  # one JSON line each

    stderr = Terminal()
    monkeypatch.setattr("sys.stderr", stderr)
    assert main(demos_argv) == 0 and main(train_argv) == 0
    bars = stderr.getvalue()
    assert "demos:" in bars and "2/2 [" in bars
    assert "train gcn seed 0:" in bars and "loss " in bars


def test_train_takes_its_thread_count_and_refuses_zero(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    import torch

    demos, checkpoint = tmp_path / "demos.mcap", tmp_path / "gcn.pt"
    assert main(["demos", "-o", str(demos), "--trajectories", "1", "--blocks", "3"]) == 0
    train_argv = ["train", str(demos), "--arch", "gcn", "--epochs", "1", "-o", str(checkpoint)]
    before = torch.get_num_threads()
    try:
        assert main([*train_argv, "--threads", "0"]) == CONFIG_EXIT_CODE
        assert "threads" in capsys.readouterr().err and not checkpoint.exists()
        assert main([*train_argv, "--threads", "1"]) == 0
        assert torch.get_num_threads() == 1 and checkpoint.exists()
    finally:
        torch.set_num_threads(before)


def test_suite_and_select_refuse_zero_threads_before_any_work(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "suite"
    assert (
        main(["suite", "--out", str(out), "--archs", "gcn", "--threads", "0"]) == CONFIG_EXIT_CODE
    )
    assert "threads" in capsys.readouterr().err and not out.exists()
    kept = tmp_path / "kept.pt"
    assert (
        main(["select", str(tmp_path / "a.pt"), "-o", str(kept), "--threads", "0"])
        == CONFIG_EXIT_CODE
    )
    assert "threads" in capsys.readouterr().err and not kept.exists()
