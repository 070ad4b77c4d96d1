"""A client of one's own plays the planner's part (examples/demonstrator.py): its actions are
demonstrations the policy trains on, on a plain and on a secure stack."""

from __future__ import annotations

import subprocess
import sys
import time
from pathlib import Path

import pytest

from manigraph_shared.mcap_log import decode_log
from manigraph_shared.messages import Action, EpisodeEvent, EpisodePhase
from manigraph_testkit.testing import stack
from manigraph_tools.certificates import make_certificates

REPO = Path(__file__).resolve().parents[2]
KITTING = REPO / "examples" / "tasks" / "kitting.toml"

pytestmark = pytest.mark.integration


def demonstrator(running: object, output: Path, *flags: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, str(REPO / "examples" / "demonstrator.py"), *flags,
         "--task-file", str(KITTING), "--episodes", "2", "-o", str(output)],
        capture_output=True, text=True, timeout=300, check=False,
        env=running.env,  # type: ignore[attr-defined]
    )  # fmt: skip


def test_a_demonstrator_of_ones_own_teaches_a_task_file(tmp_path: Path) -> None:
    with stack(tmp_path) as running:
        running.start("router")
        running.start("sim", "sim")
        running.start("skills", "skills")
        with running.client() as bus:
            running.wait_alive(bus, "sim", "skills")
        demos = tmp_path / "demos.mcap"
        result = demonstrator(running, demos, "--port", str(running.port))
        assert result.returncode == 0, result.stderr
        assert "2/2 demonstrations succeeded" in result.stderr
    messages = decode_log(demos)
    ends = [m for m in messages if isinstance(m, EpisodeEvent) and m.phase is EpisodePhase.END]
    actions = [m for m in messages if isinstance(m, Action)]
    assert [e.success for e in ends] == [True, True]
    assert len(actions) == 6 and {a.policy for a in actions} == {"demonstrator"}
    model = tmp_path / "kitting.pt"
    trained = subprocess.run(
        [sys.executable, "-m", "manigraph_shared.cli", "train", str(demos), "--arch", "sage",
         "--epochs", "3", "-o", str(model)],
        capture_output=True, text=True, timeout=600, check=False,
    )  # fmt: skip
    assert trained.returncode == 0, trained.stderr
    # The labels the demonstrations carried became the policy's feature columns.
    assert "label=bolt" in trained.stdout and "label:any" in trained.stdout


def test_on_a_secure_stack_it_needs_the_demo_ui_identity(tmp_path: Path) -> None:
    certs = tmp_path / "certs"
    make_certificates(certs)
    with stack(tmp_path, tls_dir=certs) as running:
        running.start("router")
        running.start("sim", "sim")
        running.start("skills", "skills")
        with running.client() as bus:
            running.wait_alive(bus, "sim", "skills")
        tls = ["-e", running.endpoint, "--tls-dir", str(certs)]
        as_client = [*tls, "--tls-identity", "client", "--wait", "5"]
        refused = demonstrator(running, tmp_path / "no.mcap", *as_client)
        assert refused.returncode != 0  # the client identity may reset the world, not decide
        assert "may this identity decide" in refused.stderr
        # An identity that may not even reset: refused at once, in one line, no traceback
        # (it was a traceback after the reset's 30 s).
        started = time.monotonic()
        denied = demonstrator(running, tmp_path / "none.mcap", *tls, "--tls-identity", "skills")
        assert time.monotonic() - started < 20  # a fresh Python, a session: ~2-5 s
        assert denied.returncode == 1, denied.stderr
        assert denied.stderr.strip().splitlines() == [
            "demonstrator: the reset was refused without an answer although the sim is alive: "
            "this identity may not reset the world (access denied by the router; on a secure "
            "stack present --tls-identity demo-ui)"
        ]
        allowed = demonstrator(running, tmp_path / "yes.mcap", *tls, "--tls-identity", "demo-ui")
        assert allowed.returncode == 0, allowed.stderr
        assert "2/2 demonstrations succeeded" in allowed.stderr
