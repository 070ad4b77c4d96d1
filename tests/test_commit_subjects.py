"""The commit-subject check of ``make lint`` (CONTRIBUTING.md), on a real repository."""

from __future__ import annotations

import importlib.util
import subprocess
import sys
from pathlib import Path

import pytest

SCRIPT = Path(__file__).resolve().parents[1] / "scripts" / "check_commit_subjects.py"
spec = importlib.util.spec_from_file_location("check_commit_subjects", SCRIPT)
assert spec is not None and spec.loader is not None
check = importlib.util.module_from_spec(spec)
spec.loader.exec_module(check)


@pytest.mark.parametrize(
    ("subject", "problem"),
    [
        ("planner: serve checkpoints without PyG", None),
        ("docs/physics: the seventh round", None),
        ("Fixed stuff", "does not start with 'area: '"),
        ("planner: " + "x" * 64, "73 characters"),
        ("sim: settle the bowls.", "ends with a full stop"),
    ],
)
def test_subjects_are_judged_by_the_convention(subject: str, problem: str | None) -> None:
    found = check.problems(subject)
    assert (found == []) if problem is None else any(problem in p for p in found), found


def _git(repo: Path, *args: str) -> None:
    subprocess.run(
        ["git", "-c", "user.name=t", "-c", "user.email=t@t", *args],
        cwd=repo,
        check=True,
        capture_output=True,
    )


def test_only_the_branch_s_commits_since_its_base_are_checked(tmp_path: Path) -> None:
    _git(tmp_path, "init", "-q", "-b", "main")
    _git(tmp_path, "commit", "-q", "--allow-empty", "-m", "An old subject that breaks every rule.")
    _git(tmp_path, "checkout", "-q", "-b", "work")
    _git(tmp_path, "commit", "-q", "--allow-empty", "-m", "sim: a good one")

    def run() -> subprocess.CompletedProcess[str]:
        return subprocess.run(
            [sys.executable, str(SCRIPT), "main"], cwd=tmp_path, capture_output=True, text=True
        )

    assert run().returncode == 0
    _git(tmp_path, "commit", "-q", "--allow-empty", "-m", "WIP.")
    result = run()
    assert result.returncode == 1
    assert "'WIP.': does not start with 'area: '" in result.stderr
    assert "2 since main, 2 problems" in result.stderr
