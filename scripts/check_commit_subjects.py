"""Check the subjects of this branch's commits against CONTRIBUTING.md's convention.

    python scripts/check_commit_subjects.py [BASE]

checks every commit in ``BASE..HEAD`` (BASE: ``$MANIGRAPH_COMMIT_BASE``, else ``origin/main``
if it exists, else ``main``); on the base branch itself there is nothing to check. A subject
is ``area: what it does now`` — a lower-case area (a service, ``docs``, ``tests``, ...; letters,
digits, ``-``, ``_``, ``/``), then an imperative summary of at most 72 characters in all,
without a trailing full stop. Exits 1 naming each commit that breaks a rule and the rule.
"""

from __future__ import annotations

import os
import re
import subprocess
import sys

MAX_SUBJECT = 72
AREA = re.compile(r"^[a-z0-9][a-z0-9_/\-]*: \S")


def problems(subject: str) -> list[str]:
    """What is wrong with ``subject`` (empty: nothing)."""
    found = []
    if len(subject) > MAX_SUBJECT:
        found.append(f"{len(subject)} characters (at most {MAX_SUBJECT}; detail goes in the body)")
    if not AREA.match(subject):
        found.append("does not start with 'area: ' (e.g. 'planner: ', 'docs: ')")
    if subject.endswith("."):
        found.append("ends with a full stop")
    return found


def _git(*args: str) -> str:
    return subprocess.run(["git", *args], capture_output=True, text=True, check=True).stdout


def _base() -> str:
    if len(sys.argv) > 1:
        return sys.argv[1]
    if os.environ.get("MANIGRAPH_COMMIT_BASE"):
        return os.environ["MANIGRAPH_COMMIT_BASE"]
    known = subprocess.run(
        ["git", "rev-parse", "--verify", "--quiet", "origin/main"], capture_output=True
    )
    return "origin/main" if known.returncode == 0 else "main"


def main() -> int:
    base = _base()
    commits = _git("log", "--format=%h%x00%s", f"{base}..HEAD").splitlines()
    bad = 0
    for line in commits:
        sha, subject = line.split("\0", 1)
        for problem in problems(subject):
            print(f"commit {sha} '{subject}': {problem}", file=sys.stderr)
            bad += 1
    print(f"commit subjects: {len(commits)} since {base}, {bad} problems", file=sys.stderr)
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
