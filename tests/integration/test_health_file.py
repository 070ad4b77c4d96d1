"""A service's health file is fresh while it runs on a bus and goes stale when it loses it:
what the containers' health checks read (docker/Dockerfile)."""

from __future__ import annotations

import subprocess
import time
from collections.abc import Callable
from pathlib import Path

import pytest

from manigraph_shared.health import ENVIRONMENT, FRESH_SECONDS
from manigraph_testkit.testing import stack

pytestmark = pytest.mark.integration


def fresh(path: Path, seconds: float = 3.0) -> bool:
    return path.exists() and time.time() - path.stat().st_mtime < seconds


def healthy_by_the_container_check(path: Path) -> bool:
    check = f"find '{path}' -newermt '-{FRESH_SECONDS} seconds' | grep -q ."
    return subprocess.run(["sh", "-c", check], check=False).returncode == 0


def wait_until(condition: Callable[[], bool], timeout: float = 60.0) -> bool:
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        if condition():
            return True
        time.sleep(0.2)
    return False


def test_the_health_file_follows_the_service_and_its_bus(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    with stack(tmp_path) as running:
        monkeypatch.setenv(ENVIRONMENT, str(tmp_path / "router.health"))
        running.start("router")
        monkeypatch.setenv(ENVIRONMENT, str(tmp_path / "planner.health"))
        running.start("planner", "planner")
        router, planner = tmp_path / "router.health", tmp_path / "planner.health"
        assert wait_until(lambda: fresh(router) and fresh(planner)), running.log("planner")
        assert healthy_by_the_container_check(planner)
        time.sleep(2.5)  # beats go on: still fresh by the second
        assert fresh(planner, 2.0) and fresh(router, 2.0)
        running.stop("router")
        assert not router.exists()  # a router that stops says so at once
        touched = planner.stat().st_mtime
        time.sleep(3.0)  # the planner runs on without a bus: it stops touching the file
        assert planner.stat().st_mtime - touched < 1.5
        assert running.processes["planner"].poll() is None
        running.stop("planner")
        assert not planner.exists()
        planner.touch()  # as a killed planner leaves it; a new one, with no router to find,
        running.start("planner", "planner")  # clears it before it looks for one
        assert wait_until(lambda: not planner.exists())
