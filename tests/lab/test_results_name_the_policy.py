"""Results say which policy made them (a checkpoint by its file and SHA-256) with floats
rounded, and ``train`` writes into the untracked ``runs/`` unless given ``-o``."""

from __future__ import annotations

import hashlib
import json
import re
import shutil
from pathlib import Path

import pytest

from manigraph_shared.cli import main
from manigraph_shared.results import FLOAT_DIGITS, checkpoint_field, rounded

REPO = Path(__file__).resolve().parents[2]
SAGE = REPO / "checkpoints" / "sage.pt"


def _floats_in(text: str) -> list[str]:
    return re.findall(r"-?\d+\.\d+(?:e-?\d+)?", text)


def _eval_json(argv: list[str], capsys: pytest.CaptureFixture[str]) -> tuple[str, dict]:
    assert (
        main(["eval", *argv, "--task", "stack", "--blocks", "3", "--episodes", "2", "--json"]) == 0
    )
    line = capsys.readouterr().out.strip().splitlines()[-1]
    return line, json.loads(line)


def test_eval_of_two_copies_of_a_checkpoint_names_each_file_and_its_digest(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    copy = tmp_path / "sage-seed0.pt"
    shutil.copyfile(SAGE, copy)
    digest = hashlib.sha256(SAGE.read_bytes()).hexdigest()

    line, shipped = _eval_json(["--policy", str(SAGE)], capsys)
    _, copied = _eval_json(["--policy", str(copy)], capsys)

    assert shipped["policy"] == copied["policy"] == "gnn-sage"
    assert shipped["checkpoint"] == {"path": str(SAGE), "sha256": digest}
    assert copied["checkpoint"] == {"path": str(copy), "sha256": digest}
    for number in _floats_in(line):
        assert len(number.split(".")[1]) <= FLOAT_DIGITS, number


def test_eval_of_a_registered_policy_names_no_checkpoint(
    capsys: pytest.CaptureFixture[str],
) -> None:
    line, summary = _eval_json(["--policy", "expert"], capsys)
    assert summary["policy"] == "expert" and "checkpoint" not in summary
    assert all(len(n.split(".")[1]) <= FLOAT_DIGITS for n in _floats_in(line))


def test_rounded_reaches_every_float_and_leaves_the_rest() -> None:
    value = {"a": 1 / 3, "b": [2 / 3, {"c": (0.123456789,)}], "d": 7, "e": "1.23456789", "f": True}
    assert rounded(value) == {
        "a": 0.3333,
        "b": [0.6667, {"c": [0.1235]}],
        "d": 7,
        "e": "1.23456789",
        "f": True,
    }


def test_checkpoint_field_is_empty_for_a_name_and_hashes_a_file(tmp_path: Path) -> None:
    policy = tmp_path / "p.pt"
    policy.write_bytes(b"weights")
    assert checkpoint_field("expert") == {}
    assert checkpoint_field(policy) == {
        "checkpoint": {"path": str(policy), "sha256": hashlib.sha256(b"weights").hexdigest()}
    }


def test_train_writes_into_runs_unless_given_an_output(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    monkeypatch.chdir(tmp_path)
    assert main(["demos", "-o", "demos.mcap", "--trajectories", "1", "--blocks", "3"]) == 0
    capsys.readouterr()
    assert main(["train", "demos.mcap", "--arch", "gcn", "--epochs", "1"]) == 0
    line = capsys.readouterr().out.strip().splitlines()[-1]
    written = tmp_path / "runs" / "gcn-seed0.pt"
    assert json.loads(line)["checkpoint"] == {
        "path": "runs/gcn-seed0.pt",
        "sha256": hashlib.sha256(written.read_bytes()).hexdigest(),
    }
    assert not (tmp_path / "checkpoints").exists()
    assert all(len(n.split(".")[1]) <= FLOAT_DIGITS for n in _floats_in(line))


def test_runs_is_ignored_by_git() -> None:
    assert "/runs/" in (REPO / ".gitignore").read_text().splitlines()


def test_select_names_the_checkpoint_it_wrote_by_digest(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "kept.pt"
    candidates = [str(SAGE), str(SAGE.with_name("gated.pt"))]
    assert main(["select", *candidates, "-o", str(out), "--episodes", "1", "--no-ray"]) == 0
    line = capsys.readouterr().out.strip().splitlines()[-1]
    chosen = json.loads(line)
    assert chosen["checkpoint"] == {
        "path": str(out),
        "sha256": hashlib.sha256(out.read_bytes()).hexdigest(),
    }
    assert chosen["kept"] in candidates
    assert all(len(n.split(".")[1]) <= FLOAT_DIGITS for n in _floats_in(line))
