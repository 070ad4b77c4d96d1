"""``manigraph status`` against a real stack: what each service is (version, uptime), the
planner's policy and checkpoint, and a warning when two deciders share one cell."""

from __future__ import annotations

import hashlib
import json
import shutil
import time
from importlib.metadata import version
from pathlib import Path

import pytest
from reliability_helpers import STARTUP, start

from manigraph_shared.messages import ServiceStatus
from manigraph_testkit.testing import Stack, free_port, stack
from manigraph_tools.certificates import make_certificates

pytestmark = pytest.mark.integration

CHECKPOINT = Path(__file__).resolve().parents[2] / "checkpoints" / "sage.pt"


def status_json(stack: Stack) -> dict[str, object]:
    result = stack.run("status", "--json", timeout=60)
    assert result.returncode == 0, result.stderr
    return json.loads(result.stdout.strip().splitlines()[-1])


def services_of(report: dict[str, object]) -> dict[str, dict[str, object]]:
    return {s["service"]: s for s in report["services"]}  # type: ignore[index, union-attr]


def test_status_names_each_service_the_planners_checkpoint_and_two_deciders(
    running_stack: Stack, tmp_path: Path
) -> None:
    policy = shutil.copy(CHECKPOINT, tmp_path / "policy.pt")  # immune to retraining mid-test
    start(running_stack, "sim", "skills", "planner", planner=["--policy", str(policy)])
    with running_stack.client() as bus:
        running_stack.wait_alive(bus, "sim", "skills", "planner", timeout=STARTUP)
    before = time.time()
    report = status_json(running_stack)

    assert report["endpoint"] == [running_stack.endpoint]
    assert (report["secure"], report["certificate_dir"]) == (False, None)
    assert report["cells"] == [None]
    services = services_of(report)
    assert set(services) == {"router", "sim", "skills", "planner"}
    assert all(s["alive"] for s in services.values())
    for name in ("sim", "skills", "planner"):
        assert services[name]["state"] == "ok"
        assert services[name]["version"] == version(f"manigraph-{name}")
        started = services[name]["started_at"]
        assert isinstance(started, float) and started <= before
        assert 0.0 <= services[name]["uptime_s"] <= STARTUP + 60  # type: ignore[operator]
    digest = hashlib.sha256(Path(policy).read_bytes()).hexdigest()
    assert report["checkpoint"] == {"path": str(policy), "sha256": digest}
    assert services["planner"]["checkpoint"] == report["checkpoint"]
    assert report["policy"] == services["planner"]["policy"] == "gnn-sage"
    assert report["estop_engaged"] is False
    assert report["warnings"] == []

    # A person's click page beside the planner: two deciders for one robot.
    output = tmp_path / "demos"
    running_stack.start(
        "demo-ui", "demo-ui", "--http-port", str(free_port()), "--output", str(output)
    )
    with running_stack.client() as bus:
        running_stack.wait_alive(bus, "demo-ui", timeout=STARTUP)
    report = status_json(running_stack)
    (warning,) = report["warnings"]  # type: ignore[misc]
    assert warning.startswith("two deciders alive in the default cell (planner, demo-ui)")
    text = running_stack.run("status", timeout=60)
    assert "WARNING: two deciders alive" in text.stdout
    assert f"sha256 {digest}" in text.stdout


def test_status_without_a_stack_says_so_naming_the_endpoint(tmp_path: Path) -> None:
    stack = Stack(free_port(), tmp_path)
    result = stack.run("status", "--json", timeout=60)
    assert result.returncode != 0
    (line,) = result.stderr.strip().splitlines()[-1:]
    assert line.startswith(f"manigraph status: no stack at {stack.endpoint}")


def test_a_status_of_an_older_service_still_decodes() -> None:
    old = b'{"service":"sim","state":"ok","detail":"","messages_in":3,"stamp":1.5}'
    status = ServiceStatus.decode(old)
    assert (status.version, status.started_at, status.estop, status.checkpoint) == (
        "",
        None,
        None,
        None,
    )


def test_status_on_a_secure_stack_names_its_certificates_and_each_service(
    tmp_path: Path,
) -> None:
    certs = tmp_path / "certs"
    make_certificates(certs)
    with stack(tmp_path, tls_dir=certs) as running:
        start(running, "sim", "skills")
        with running.client() as bus:
            running.wait_alive(bus, "sim", "skills", timeout=STARTUP)
            # The router grants a client the status query, and each service its answer.
            (reply,) = list(bus.session.get(ServiceStatus.key.format(service="sim"), timeout=10))
            assert reply.ok is not None, reply.err
            assert ServiceStatus.decode(reply.ok.payload.to_bytes()).service == "sim"
        report = status_json(running)
    assert report["endpoint"] == [running.endpoint]
    assert (report["secure"], report["certificate_dir"]) == (True, str(certs))
    services = services_of(report)
    assert services["sim"]["version"] == version("manigraph-sim")
    assert services["skills"]["state"] == "ok"


def test_status_sees_every_cell_its_stop_and_two_planners_in_one(running_stack: Stack) -> None:
    running_stack.start("router")
    running_stack.start("sim-left", "sim", "--cell", "left")
    running_stack.start("skills-left", "skills", "--cell", "left")
    for name in ("planner-left", "planner-left-again"):
        running_stack.start(name, "planner", "--cell", "left")
    with running_stack.client() as bus:
        running_stack.wait_alive(bus.in_cell("left"), "sim", "skills", "planner", timeout=STARTUP)
    stopped = running_stack.run("stop", "--cell", "left", "--reason", "left door", timeout=60)
    assert stopped.returncode == 0, stopped.stderr
    report = status_json(running_stack)
    assert report["cells"] == [None, "left"]
    by_cell = {(s["cell"], s["service"]): s for s in report["services"]}  # type: ignore[union-attr]
    assert set(by_cell) == {
        (None, "router"),
        ("left", "sim"),
        ("left", "skills"),
        ("left", "planner"),
    }
    assert report["estop_engaged"] is True
    assert report["estop"]["cell"] == "left"  # type: ignore[index]
    assert report["estop"]["reason"] == "left door"  # type: ignore[index]
    (warning,) = report["warnings"]  # type: ignore[misc]
    assert warning.startswith("two deciders alive in cell left (planner x2)")


def test_status_flags_a_second_skills_process_and_each_services_view_of_the_stop(
    running_stack: Stack,
) -> None:
    start(running_stack, "sim", "skills")
    running_stack.start("skills-2", "skills")  # a second skills on the same robot
    with running_stack.client() as bus:
        running_stack.wait_alive(bus, "sim", "skills", timeout=STARTUP)
        time.sleep(1.5)  # both heartbeats
    report = status_json(running_stack)
    warnings = report["warnings"]
    assert any(w.startswith("2 skills processes alive in the default cell") for w in warnings)
    services = services_of(report)
    assert services["sim"]["estop"] == {"engaged": False, "known": True}
    assert report["estop_latch"]["default"]["engaged"] is False  # type: ignore[index]
