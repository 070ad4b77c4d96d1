"""The container path users take: build, `docker compose up`, an episode, a killed service.

The stack runs as compose.yaml ships it: mutual TLS and the router's access control, with
certificates made by the one-shot `certs` service; a client without a certificate (or with
the wrong one) cannot publish a decision.

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
import zenoh

from manigraph_shared.bus import Bus
from manigraph_shared.bus_config import BusConfig
from manigraph_shared.mcap_log import read_log
from manigraph_shared.messages import Action, EpisodeEvent, JointState
from manigraph_testkit.testing import free_port, open_raw_session

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
        self.port = port
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

    def copy_certificate(self, name: str, into: Path) -> Path:
        """One file of the stack's `certs` volume, read through the tools image."""
        result = self("run", "--rm", "--no-deps", "-T", "tools", "cat", f"/certs/{name}")
        (into / name).write_text(result.stdout)
        return into / name

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
        stack("down", "--volumes", "--remove-orphans", "--timeout", "20", check=False)


def recorded(logs: Path, since: float) -> tuple[list[EpisodeEvent], list[Action], int]:
    """From the MCAP logs written since ``since``: episode end events, actions, and how
    many ``JointState`` messages (the physics Panda's joints) were recorded."""
    ends: list[EpisodeEvent] = []
    actions: list[Action] = []
    joint_states = 0
    for path in logs.glob("*.mcap"):
        if path.stat().st_mtime < since:
            continue
        for item in read_log(path, [EpisodeEvent.key, Action.key, JointState.key]):
            if item.topic == EpisodeEvent.key:
                event = EpisodeEvent.decode(item.data)
                if event.phase == "end":
                    ends.append(event)
            elif item.topic == Action.key:
                actions.append(Action.decode(item.data))
            else:
                joint_states += 1
    return ends, actions, joint_states


def test_physics_episodes_with_the_gnn_succeed_inside_containers_and_land_in_logs(
    compose: Compose,
) -> None:
    # The default stack: the SAPIEN Panda (physics sim, panda-sim driver) and Sage.
    started = time.time()
    compose.wait_healthy(["router", "recorder", "sim", "planner", "skills"])
    result = compose.tools("run", "--blocks", "4", "--episodes", "3", "--seed", "1", timeout=600)
    assert result.returncode == 0, result.stderr[-3000:]
    summary = json.loads(result.stdout.strip().splitlines()[-1])
    assert summary["success_rate"] == 1.0
    time.sleep(1.0)  # the recorder flushes every 100 ms
    ends, actions, joint_states = recorded(compose.logs, started)
    ran = {r["episode_id"] for r in summary["results"]}
    ended = {e.episode_id: e for e in ends}
    assert ran <= ended.keys() and all(ended[e].success for e in ran)
    assert joint_states > 0  # the physics world's arm, not the geometric world
    ours = [a for a in actions if a.episode_id in ran]
    assert ours and {a.policy for a in ours} == {"gnn-sage"}


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


def test_a_client_without_a_certificate_cannot_publish_an_action(
    compose: Compose, tmp_path: Path
) -> None:
    compose.wait_healthy(["router", "sim", "planner", "skills"])
    endpoint = f"tls/127.0.0.1:{compose.port}"  # the router's published port, from the host
    ca = compose.copy_certificate("ca.pem", tmp_path)
    with pytest.raises(zenoh.ZError):  # plain TCP, as before this stack had TLS
        open_raw_session(endpoint.replace("tls/", "tcp/"))
    with pytest.raises(zenoh.ZError):  # TLS that trusts the router but shows no certificate
        open_raw_session(endpoint, root_ca_certificate=str(ca))
    # a valid certificate of the wrong identity connects, but its decision reaches no one
    for name in ("client.pem", "client.key", "recorder.pem", "recorder.key"):
        compose.copy_certificate(name, tmp_path)
    seen: list[str] = []

    def config(identity: str) -> BusConfig:
        return BusConfig(
            connect=(endpoint,), tls_dir=tmp_path, tls_identity=identity, wait_seconds=10
        )

    with Bus.open(config("client")) as watcher, Bus.open(config("recorder")) as forger:
        watcher.subscribe(Action, lambda action: seen.append(action.episode_id))
        time.sleep(0.5)
        forger.publish(
            Action(
                decision_id="forged:0",
                episode_id="forged",
                scene_sequence=0,
                object_id="block_0",
                goal_id="goal_0",
                policy="forger",
                stamp=time.time(),
            )
        )
        result = compose.tools("run", "--blocks", "3", "--episodes", "1", "--seed", "2")
        assert result.returncode == 0, result.stderr[-3000:]
        time.sleep(0.5)
    assert seen, "the episode's own decisions reach an authorised reader"
    assert "forged" not in seen


@pytest.fixture(scope="module")
def camera_compose(compose: Compose) -> Iterator[Compose]:
    """The camera profile (images built by ``compose``), the sim stack stopped first."""
    compose("stop", check=False)
    stack = Compose(f"manigraph-camera-{os.getpid()}", compose.logs, free_port(), "camera")
    try:
        stack("up", "-d")
        yield stack
    finally:
        stack("down", "--volumes", "--remove-orphans", "--timeout", "20", check=False)


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
