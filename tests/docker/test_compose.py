"""The container path users take: build, `docker compose up`, an episode, a killed service.

Works with `docker compose` (v2) and the older `docker-compose` (v1, what Debian 12 ships).

Runs whenever a Docker engine answers; otherwise it is reported as skipped, with the reason.
Every run uses its own compose project name and router port, and always ends with
`docker compose down`.
"""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import time
from collections.abc import Iterator
from pathlib import Path

import pytest

from manigraph_shared.mcap_log import read_log
from manigraph_shared.messages import EpisodeEvent
from manigraph_tools.testing import free_port

# The first test also builds every image: cold, on a fresh engine, that takes 6-15 minutes
# (the torch wheels), far past the suite's 300 s per-test limit.
pytestmark = [pytest.mark.docker, pytest.mark.integration, pytest.mark.timeout(2700)]

REPO = Path(__file__).resolve().parents[2]


def compose_command() -> list[str] | None:
    """`docker compose` (v2) where installed, else the `docker-compose` (v1) tool."""
    v2 = subprocess.run(
        ["docker", "compose", "version"], capture_output=True, text=True, check=False
    )
    if v2.returncode == 0 and "compose" in v2.stdout.lower():  # old CLIs exit 0 here too
        return ["docker", "compose"]
    if shutil.which("docker-compose") is not None:
        return ["docker-compose"]
    return None


def docker_available() -> str | None:
    if shutil.which("docker") is None:
        return "no docker command on this machine"
    if subprocess.run(["docker", "info"], capture_output=True, check=False).returncode != 0:
        return "the Docker engine does not answer"
    if compose_command() is None:
        return "neither `docker compose` nor `docker-compose` is installed"
    return None


class Compose:
    def __init__(self, project: str, logs: Path, port: int, profiles: str = "sim") -> None:
        self.command = compose_command() or ["docker", "compose"]
        self.project = project
        self.logs = logs
        self.env = {
            **os.environ,
            "COMPOSE_PROJECT_NAME": project,
            "COMPOSE_PROFILES": profiles,
            "MANIGRAPH_ROUTER_PORT": str(port),
        }

    def __call__(
        self, *args: str, timeout: float = 300, check: bool = True
    ) -> subprocess.CompletedProcess[str]:
        result = subprocess.run(
            [*self.command, *args],
            cwd=REPO,
            env=self.env,
            capture_output=True,
            text=True,
            timeout=timeout,
            check=False,
        )
        if check and result.returncode != 0:
            raise AssertionError(
                f"{' '.join([*self.command, *args])}:\n{result.stdout}\n{result.stderr}"
            )
        return result

    def tools(self, *args: str, timeout: float = 300) -> subprocess.CompletedProcess[str]:
        return self(
            "run", "--rm", "--no-deps", "tools", "manigraph", *args, timeout=timeout, check=False
        )

    def health(self, service: str) -> str:
        container = self("ps", "-q", service, check=False).stdout.strip()
        if not container:
            return "absent"
        inspect = subprocess.run(
            ["docker", "inspect", "--format", "{{.State.Health.Status}}", container],
            capture_output=True,
            text=True,
            check=False,
        )
        return inspect.stdout.strip() or "unknown"

    def wait_healthy(self, services: list[str], timeout: float = 180) -> None:
        deadline = time.monotonic() + timeout
        states: dict[str, str] = {}
        while time.monotonic() < deadline:
            states = {name: self.health(name) for name in services}
            if all(state == "healthy" for state in states.values()):
                return
            time.sleep(2)
        raise AssertionError(
            f"not healthy after {timeout} s: {states}\n{self('logs', check=False).stdout[-4000:]}"
        )


@pytest.fixture(scope="module")
def compose() -> Iterator[Compose]:
    reason = docker_available()
    if reason is not None:
        pytest.skip(f"compose test skipped: {reason}")
    build = subprocess.run(
        ["bash", str(REPO / "docker" / "build.sh")],
        cwd=REPO,
        capture_output=True,
        text=True,
        timeout=3600,
        check=False,
    )
    assert build.returncode == 0, build.stdout[-4000:] + build.stderr[-4000:]
    logs = REPO / "logs"
    logs.mkdir(exist_ok=True)
    logs.chmod(0o777)  # the images run as uid 1000
    stack = Compose(f"manigraph-test-{os.getpid()}", logs, free_port())
    try:
        stack("up", "-d")
        yield stack
    finally:
        stack("down", "--remove-orphans", "--timeout", "20", check=False)


def ended_episodes(logs: Path, since: float) -> list[EpisodeEvent]:
    events = []
    for path in logs.glob("*.mcap"):
        if path.stat().st_mtime < since:
            continue
        for item in read_log(path, [EpisodeEvent.key]):
            event = EpisodeEvent.decode(item.data)
            if event.phase == "end":
                events.append(event)
    return events


def test_an_episode_succeeds_inside_containers_and_lands_in_logs(compose: Compose) -> None:
    started = time.time()
    compose.wait_healthy(["router", "recorder", "sim", "planner", "skills"])
    result = compose.tools("run", "--blocks", "4", "--episodes", "2", "--seed", "1")
    assert result.returncode == 0, result.stderr[-3000:]
    summary = json.loads(result.stdout.strip().splitlines()[-1])
    assert summary["success_rate"] == 1.0
    time.sleep(1.0)  # the recorder flushes every 100 ms
    ends = {e.episode_id: e for e in ended_episodes(compose.logs, started)}
    ran = {r["episode_id"] for r in summary["results"]}
    assert ran <= ends.keys() and all(ends[e].success for e in ran)


def test_a_killed_planner_is_reported_missing_and_recovers(compose: Compose) -> None:
    compose.wait_healthy(["router", "sim", "planner", "skills"])
    compose("kill", "planner")
    time.sleep(2.0)
    doctor = compose.tools("doctor", "--json")
    assert doctor.returncode == 1
    assert "planner" in json.loads(doctor.stdout.strip().splitlines()[-1])["missing"]
    compose("start", "planner")
    compose.wait_healthy(["planner"])
    result = compose.tools("run", "--blocks", "3", "--episodes", "1", "--seed", "9")
    assert result.returncode == 0, result.stderr[-3000:]
    assert json.loads(result.stdout.strip().splitlines()[-1])["success_rate"] == 1.0


@pytest.fixture(scope="module")
def camera_compose(compose: Compose) -> Iterator[Compose]:
    """The camera profile (images built by ``compose``), the sim stack stopped first."""
    compose("stop", check=False)
    stack = Compose(f"manigraph-camera-{os.getpid()}", compose.logs, free_port(), "camera")
    try:
        stack("up", "-d")
        yield stack
    finally:
        stack("down", "--remove-orphans", "--timeout", "20", check=False)


def test_an_episode_through_the_camera_profile(camera_compose: Compose) -> None:
    """Physics sim with its rendered camera, perception the only Scene source, the Panda."""
    camera_compose.wait_healthy(
        ["router", "sim-camera", "perception-sim", "planner", "skills-panda"], timeout=400
    )
    result = camera_compose.tools(
        "run", "--blocks", "2", "--episodes", "1", "--seed", "0", timeout=600
    )
    assert result.returncode == 0, result.stderr[-3000:]
    assert json.loads(result.stdout.strip().splitlines()[-1])["success_rate"] == 1.0
