"""A real stack: router, sim, planner, skills (and recorder) as processes on loopback."""

from __future__ import annotations

import json
import time
from pathlib import Path

import pytest
from mcap.reader import make_reader

from manigraph_shared.errors import CONFIG_EXIT_CODE
from manigraph_shared.mcap_log import read_log
from manigraph_shared.messages import Action, EpisodeEvent, Scene, ServiceStatus
from manigraph_testkit.testing import Stack, free_port, record_then_kill, run_up

pytestmark = pytest.mark.integration


def last_json(output: str) -> dict[str, object]:
    return json.loads(output.strip().splitlines()[-1])


def test_up_runs_episodes_to_success_and_records_them(tmp_path: Path) -> None:
    log = tmp_path / "run.mcap"
    result = run_up(
        "--task",
        "stack",
        "--blocks",
        "6",
        "--episodes",
        "3",
        "--seed",
        "0",
        "--record",
        str(log),
        timeout=120,
    )
    summary = last_json(result.stdout)
    assert summary["episodes"] == 3
    assert summary["success_rate"] == 1.0
    assert summary["goals_filled_rate"] == 1.0
    assert "episode 3/3" in result.stderr  # progress while it runs

    with log.open("rb") as stream:
        mcap_summary = make_reader(stream).get_summary()
    assert mcap_summary is not None
    schemas = {
        channel.topic: mcap_summary.schemas[channel.schema_id].name
        for channel in mcap_summary.channels.values()
    }
    assert schemas[Scene.key] == "manigraph.Scene"
    assert schemas[Action.key] == "manigraph.Action"
    ends = [
        m.decode()
        for m in read_log(log, [EpisodeEvent.key])
        if json.loads(m.data)["phase"] == "end"
    ]
    assert len(ends) == 3 and all(e.success for e in ends)  # type: ignore[attr-defined]
    actions = list(read_log(log, [Action.key]))
    assert len(actions) == sum(r["steps"] for r in summary["results"])  # type: ignore[index, union-attr]


def test_start_order_does_not_matter(running_stack: Stack) -> None:
    for name in ("sim", "planner", "skills"):
        running_stack.start(name, name)
    time.sleep(2.0)  # services are up and waiting before the router exists
    running_stack.start("router")
    result = running_stack.run(
        "run", "--task", "stack", "--blocks", "4", "--episodes", "2", "--seed", "5"
    )
    assert result.returncode == 0, result.stderr[-3000:] + running_stack.log("sim")
    assert last_json(result.stdout)["success_rate"] == 1.0


def test_bad_payloads_are_reported_and_the_services_keep_running(running_stack: Stack) -> None:
    running_stack.start("router")
    for name in ("sim", "planner", "skills"):
        running_stack.start(name, name)
    statuses: list[ServiceStatus] = []
    with running_stack.client() as bus:
        running_stack.wait_alive(bus, "router", "sim", "planner", "skills")
        bus.subscribe(ServiceStatus, statuses.append)
        time.sleep(0.3)
        bus.session.put(Action.key, b'{"decision_id": "e:0", "object_id": 7}')  # -> skills
        bus.session.put(Scene.key, b'{"episode_id": "e", "stamp": NaN')  # -> planner, skills
        deadline = time.monotonic() + 10
        while time.monotonic() < deadline:
            errors = {(s.service, s.detail) for s in statuses if s.state == "error"}
            if {s for s, _ in errors} >= {"skills", "planner"}:
                break
            time.sleep(0.1)
        errors = {(s.service, s.detail) for s in statuses if s.state == "error"}
        skills_errors = " ".join(d for s, d in errors if s == "skills")
        assert "bad manigraph.Action" in skills_errors
        assert "object_id: Expected `str`" in skills_errors
        assert any(s == "planner" and "manigraph.Scene" in d for s, d in errors)
        assert {"sim", "planner", "skills"} <= bus.alive_services()
    result = running_stack.run("run", "--blocks", "3", "--episodes", "1")
    assert result.returncode == 0 and last_json(result.stdout)["success_rate"] == 1.0


def test_recorder_killed_hard_keeps_everything_older_than_its_last_flush(
    running_stack: Stack, tmp_path: Path
) -> None:
    killed = record_then_kill(running_stack, tmp_path / "killed.mcap")
    recovered = {Action.decode(m.data).scene_sequence for m in read_log(killed.log, [Action.key])}
    # Flushed every 100 ms; allow the same again for delivery and scheduling on a busy CI box.
    must_have = killed.flushed_before(0.2)
    assert len(must_have) > 100
    assert must_have <= recovered, f"lost {len(must_have - recovered)} flushed messages"


def test_doctor_names_missing_services_and_sees_a_killed_one_go(running_stack: Stack) -> None:
    running_stack.start("router")
    running_stack.start("planner", "planner")
    with running_stack.client() as bus:
        running_stack.wait_alive(bus, "planner")
    result = running_stack.run("doctor", "--json")
    assert result.returncode == 1
    report = json.loads(result.stdout)
    assert set(report["missing"]) == {"sim", "skills"}
    assert {"router", "planner"} <= set(report["alive"])
    assert running_stack.run("doctor", "--expect", "router", "planner").returncode == 0

    running_stack.processes["planner"].kill()
    running_stack.processes["planner"].wait()
    time.sleep(1.0)
    result = running_stack.run("doctor", "--expect", "router", "planner")
    assert result.returncode == 1
    assert "| planner | MISSING |" in result.stdout


def test_doctor_without_a_router_reports_everything_missing(tmp_path: Path) -> None:
    stack = Stack(free_port(), tmp_path)
    result = stack.run("doctor", "--json", "--timeout", "1")
    assert result.returncode == 1
    assert set(json.loads(result.stdout)["missing"]) == {"router", "sim", "planner", "skills"}


def test_a_bad_task_file_is_refused_by_the_sim_with_the_field_named(
    running_stack: Stack, tmp_path: Path
) -> None:
    running_stack.start("router")
    for name in ("sim", "planner", "skills"):
        running_stack.start(name, name)
    bad = tmp_path / "bad.toml"
    bad.write_text('[[objects]]\nid = "a"\ncategory = "ball"\nposition = [0.5, 0, 0.02]\n')
    result = running_stack.run("run", "--task-file", str(bad), "--episodes", "1")
    assert result.returncode == CONFIG_EXIT_CODE  # refused by the sim: the same as eval's
    assert "objects.0.category" in result.stderr and "goals" in result.stderr
    with running_stack.client() as bus:
        assert {"sim", "planner", "skills"} <= bus.alive_services()  # nothing crashed
