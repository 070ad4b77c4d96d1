"""Cells on one router: each cell's messages, queries and liveliness stay in that cell."""

from __future__ import annotations

import json
import threading
from dataclasses import replace

import pytest

from manigraph_shared.bus import Bus
from manigraph_shared.errors import BusError
from manigraph_shared.messages import EpisodeEvent, EpisodeRequest, Scene
from manigraph_testkit.testing import Stack, run_up

pytestmark = pytest.mark.integration


def scene(episode: str) -> Scene:
    return Scene(episode_id=episode, stamp=1.0, sequence=0, objects=[], goals=[])


def collect(bus: Bus) -> tuple[list[str], threading.Event]:
    seen: list[str] = []
    got = threading.Event()

    def on_scene(message: Scene) -> None:
        seen.append(message.episode_id)
        got.set()

    bus.subscribe(Scene, on_scene)
    return seen, got


def test_a_scene_reaches_its_own_cell_only(running_stack: Stack) -> None:
    running_stack.start("router")
    config = running_stack.bus_config()
    with (
        Bus.open(replace(config, cell="left")) as left,
        Bus.open(replace(config, cell="right")) as right,
        Bus.open(config) as default,
    ):
        seen = {
            name: collect(bus)
            for name, bus in (("left", left), ("right", right), ("default", default))
        }
        with Bus.open(config) as probe:  # the router is up once a session opens
            probe.alive_services(timeout=0.5)
        for name, bus in (("left", left), ("right", right), ("default", default)):
            bus.publish(scene(f"from-{name}"))
        for name, (_, got) in seen.items():
            assert got.wait(10.0), name
        threading.Event().wait(0.3)  # anything misrouted would have arrived by now
        assert {name: ids for name, (ids, _) in seen.items()} == {
            "left": ["from-left"],
            "right": ["from-right"],
            "default": ["from-default"],
        }


def test_a_query_is_answered_by_its_own_cell_and_liveliness_is_per_cell(
    running_stack: Stack,
) -> None:
    running_stack.start("router")
    config = running_stack.bus_config()
    with (
        Bus.open(replace(config, cell="left")) as left,
        Bus.open(replace(config, cell="right")) as right,
    ):
        left.declare_alive("sim")

        def answer(request: EpisodeRequest) -> EpisodeEvent:
            return EpisodeEvent(
                episode_id=request.episode_id,
                phase="start",
                stamp=0.0,
                task=request.task,
                seed=request.seed,
                goals_total=0,
                goals_filled=0,
            )

        left.serve(EpisodeRequest, answer)
        request = EpisodeRequest(episode_id="e1", task="stack", blocks=3, seed=0)
        reply = left.request(request, EpisodeEvent, timeout=10.0)
        assert reply.episode_id == "e1"
        with pytest.raises(BusError, match="no answer"):
            right.request(request, EpisodeEvent, timeout=1.0)
        assert "sim" in left.alive_services(timeout=2.0)
        assert right.alive_services(timeout=1.0) == set()


def test_up_runs_each_cell_on_its_own_seeds_and_reports_each() -> None:
    result = run_up("--cells", "2", "--blocks", "3", "--episodes", "2", "--seed", "5", "--json")
    summary = json.loads(result.stdout)
    assert summary["success_rate_by_cell"] == {"cell-1": 1.0, "cell-2": 1.0}
    assert summary["episodes"] == 4 and summary["success_rate"] == 1.0
    seeds = {cell: [r["seed"] for r in s["results"]] for cell, s in summary["cells"].items()}
    assert seeds == {"cell-1": [5, 6], "cell-2": [7, 8]}
    assert "[cell-2] episode 2/2" in result.stderr
    # One planner process served both cells (each cell its own sim and skills).
    up_line = next(line for line in result.stderr.splitlines() if "stack is up:" in line)
    processes = up_line.split("stack is up: ", 1)[1].rsplit(" (", 1)[0].split(", ")
    assert sorted(processes) == sorted(
        ["router", "planner", "sim@cell-1", "skills@cell-1", "sim@cell-2", "skills@cell-2"]
    )


def test_up_can_still_start_a_planner_per_cell() -> None:
    result = run_up("--cells", "2", "--planner-per-cell", "--blocks", "3", "--episodes", "1")
    assert "planner@cell-1" in result.stderr and "planner@cell-2" in result.stderr
    summary = json.loads(result.stdout.splitlines()[-1])
    assert summary["success_rate_by_cell"] == {"cell-1": 1.0, "cell-2": 1.0}
