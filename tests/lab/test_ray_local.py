"""A local Ray session leaves nothing behind: no worker environment built under ``uv run``, no
session folder once ``manigraph suite`` ends, also when it is stopped by a signal (issue 51).

Each test starts and stops its own local Ray (seconds), so no other session may be open in this
process: these sit apart from ``test_sweep_ray.py``, whose module keeps one open.
"""

from __future__ import annotations

import os
import signal
import sys
from collections.abc import Iterator
from pathlib import Path

import pytest

from manigraph_lab.demo_recording import DemoProtocol, record_demos
from manigraph_lab.ray_local import TEMP_PREFIX, temp_root
from manigraph_lab.sweep import Job, Outcome, SweepOptions, run_jobs
from manigraph_planner.policies import load_policy
from manigraph_shared.cli import main

pytestmark = pytest.mark.integration


def _session_folders() -> list[Path]:
    """This process's Ray session folders: ours under the temporary root, and any in Ray's
    default ``/tmp/ray`` (named ``session_<date>_<pid of the driver>``)."""
    ours = Path(temp_root()).glob(f"{TEMP_PREFIX}{os.getpid()}-*")
    default = Path("/tmp/ray").glob(f"session_*_{os.getpid()}")
    return sorted([*ours, *default])


@pytest.fixture
def under_uv_run(monkeypatch: pytest.MonkeyPatch) -> Iterator[None]:
    """Ray sees this process as run by ``uv run`` (as the README runs ``manigraph suite``):
    left to itself it would give the workers a ``uv run`` interpreter in a copy of the
    working directory, syncing a virtual environment there first."""
    os.environ.setdefault("RAY_USAGE_STATS_ENABLED", "0")
    import ray
    from ray._private.runtime_env import uv_runtime_env_hook

    assert not ray.is_initialized()
    monkeypatch.delenv("RAY_ENABLE_UV_RUN_RUNTIME_ENV", raising=False)
    command = ["uv", "run", "--frozen", "manigraph", "suite"]
    monkeypatch.setattr(uv_runtime_env_hook, "_get_uv_run_cmdline", lambda: command)
    assert _session_folders() == []
    yield
    assert not ray.is_initialized()


def test_suite_leaves_no_session_behind(
    under_uv_run: None, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "out"
    out.mkdir()
    record_demos(load_policy("expert"), DemoProtocol(trajectories=4), out / "demos.mcap", None)
    tiny = ["--archs", "gcn", "--seeds", "0", "--epochs", "1", "--episodes", "1"]
    status = main(["suite", "-o", str(out), *tiny, "--curve-episodes", "0", "--workers", "2"])
    if status != 0 and "timed out during startup" in capsys.readouterr().err:
        assert _session_folders() == []  # a session that never started is removed too
        pytest.skip(
            f"Ray's node did not start within its fixed 30 s (load {os.getloadavg()[0]:.0f} "
            f"on {os.cpu_count()} cores): needs a machine where Ray can start"
        )
    assert status == 0
    assert "| gcn |" in (out / "generalization.md").read_text()
    assert _session_folders() == []


def test_workers_run_this_interpreter_and_a_stop_signal_cleans_up(under_uv_run: None) -> None:
    seen: dict[str, object] = {}
    handler = signal.getsignal(signal.SIGTERM)

    def stop_after_first(job: Job, outcome: Outcome) -> None:
        seen[job.name] = outcome.value
        if job.name == "interpreter":
            seen["folders"] = _session_folders()
            os.kill(os.getpid(), signal.SIGTERM)  # as `kill <pid>` stops `manigraph suite`

    jobs = [Job("interpreter", getattr, (sys, "executable")), Job("later", abs, (-1,))]
    with pytest.raises(KeyboardInterrupt, match="SIGTERM"):
        run_jobs(jobs, SweepOptions(workers=2), on_done=stop_after_first)
    assert seen["interpreter"] == sys.executable  # no environment built for the workers
    folders = seen["folders"]
    assert isinstance(folders, list) and len(folders) == 1  # Ray's session was in our folder
    assert folders[0].name.startswith(TEMP_PREFIX)
    assert _session_folders() == []
    assert signal.getsignal(signal.SIGTERM) is handler  # put back
