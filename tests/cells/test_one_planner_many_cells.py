"""One planner process serving several cells: each cell decides on its own, never another's
scenes, and a stalled or dead cell holds no other cell's decisions up."""

from __future__ import annotations

import subprocess
import sys
import threading
import time
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import replace

import pytest

from manigraph_blocks.planner.expert import ExpertPolicy
from manigraph_planner.policies.base import Decision, Policy
from manigraph_planner.service import PlannerService
from manigraph_shared.bus import Bus
from manigraph_shared.cell_services import CellServices
from manigraph_shared.errors import RequestRefused
from manigraph_shared.messages import (
    EXPLAINER_WARMING_UP,
    Action,
    ExplainRequest,
    Explanation,
    Scene,
    SceneGoal,
    SceneObject,
    SkillState,
    SkillStatus,
    Vector3,
)
from manigraph_testkit.testing import Stack

pytestmark = pytest.mark.integration

BLOCK = 0.04


def two_block_scene(episode: str, stamp: float, sequence: int) -> Scene:
    """Two blocks in a tower, two block goals in another: the expert always has a move."""
    return Scene(
        episode_id=episode,
        stamp=stamp,
        sequence=sequence,
        objects=[
            SceneObject(
                id=f"b{i}",
                category="block",
                position=Vector3(x=0.5, y=-0.2, z=(i + 0.5) * BLOCK),
                size=Vector3(x=BLOCK, y=BLOCK, z=BLOCK),
            )
            for i in range(2)
        ],
        goals=[
            SceneGoal(
                id=f"g{i}", category="block", position=Vector3(x=0.5, y=0.2, z=(i + 0.5) * BLOCK)
            )
            for i in range(2)
        ],
    )


class Actions:
    """The actions one cell's bus receives, by arrival."""

    def __init__(self, bus: Bus) -> None:
        self.items: list[Action] = []
        self._arrived = threading.Condition()
        bus.subscribe(Action, self._on_action)

    def _on_action(self, action: Action) -> None:
        with self._arrived:
            self.items.append(action)
            self._arrived.notify_all()

    def wait_for(self, decision_id: str, timeout: float) -> Action:
        deadline = time.monotonic() + timeout
        with self._arrived:
            while True:
                found = [a for a in self.items if a.decision_id == decision_id]
                if found:
                    return found[0]
                left = deadline - time.monotonic()
                assert left > 0, f"no action {decision_id} within {timeout} s: {self.ids()}"
                self._arrived.wait(left)

    def ids(self) -> list[str]:
        return [a.decision_id for a in self.items]


def drive(bus: Bus, actions: Actions, episode: str, decisions: int, timeout: float) -> list[float]:
    """``decisions`` steps of ``episode``: scene, its action, the skill's success; the seconds
    from each scene to its action."""
    waits = []
    for step in range(decisions):
        stamp = time.time()
        started = time.monotonic()
        bus.publish(two_block_scene(episode, stamp, step))
        action = actions.wait_for(f"{episode}:{step}", timeout)
        waits.append(time.monotonic() - started)
        assert action.episode_id == episode and action.scene_sequence == step
        bus.publish(
            SkillStatus(
                decision_id=action.decision_id,
                skill="pick_and_place",
                state=SkillState.SUCCEEDED,
                stamp=time.time(),
            )
        )
    return waits


@contextmanager
def cell_buses(stack: Stack, *cells: str) -> Iterator[dict[str, Bus]]:
    config = stack.bus_config()
    buses = {cell: Bus.open(replace(config, cell=cell)) for cell in cells}
    try:
        yield buses
    finally:
        for bus in buses.values():
            bus.close()


def test_one_planner_process_decides_in_each_cell_and_only_there(running_stack: Stack) -> None:
    running_stack.start("router")
    running_stack.start("planner", "planner", "--policy", "expert", "--cells", "left,right")
    with cell_buses(running_stack, "left", "right") as buses:
        for bus in buses.values():  # one liveliness token per cell served
            running_stack.wait_alive(bus, "planner")
        actions = {cell: Actions(bus) for cell, bus in buses.items()}
        # The left cell's skills never answer: its first decision stays pending.
        buses["left"].publish(two_block_scene("ep-left", time.time(), 0))
        assert actions["left"].wait_for("ep-left:0", 30.0).episode_id == "ep-left"
        # Meanwhile the right cell goes through a whole episode, decision after decision,
        # with its own decision ids.
        drive(buses["right"], actions["right"], "ep-right", decisions=4, timeout=10.0)
        time.sleep(0.3)  # anything misrouted would have arrived by now
        assert actions["left"].ids() == ["ep-left:0"]
        assert actions["right"].ids() == [f"ep-right:{step}" for step in range(4)]


def test_each_cell_explains_its_own_decisions_only(running_stack: Stack) -> None:
    running_stack.start("router")
    policy = "checkpoints/sage.pt"
    running_stack.start("planner", "planner", "--policy", policy, "--cells", "left,right")
    with cell_buses(running_stack, "left", "right") as buses:
        for bus in buses.values():  # torch first: on a loaded machine this takes a while
            running_stack.wait_alive(bus, "planner", timeout=180.0)
        actions = Actions(buses["left"])
        buses["left"].publish(two_block_scene("ep-left", time.time(), 0))
        decided = actions.wait_for("ep-left:0", 30.0)
        # The explainer may still be warming up: asked again, as `manigraph explain` does.
        why = explain(buses["left"], "ep-left:0")
        assert why.decision_id == "ep-left:0"
        assert (why.object, why.goal) == (decided.object_id, decided.goal_id)
        with pytest.raises(RequestRefused, match="decision_id"):  # not the right cell's
            explain(buses["right"], "ep-left:0")


def explain(bus: Bus, decision_id: str, within: float = 60.0) -> Explanation:
    """The planner's explanation, asked again while its explainer warms up."""
    deadline = time.monotonic() + within
    while True:
        try:
            return bus.request(ExplainRequest(decision_id=decision_id), Explanation, within)
        except RequestRefused as exc:
            if EXPLAINER_WARMING_UP not in str(exc) or time.monotonic() > deadline:
                raise
            time.sleep(0.1)


def test_a_bad_cell_list_stops_the_planner_naming_cells() -> None:
    for argv in (["--cells", "left,Left"], ["--cells", "a,a"], ["--cells", "a", "--cell", "b"]):
        result = subprocess.run(
            [sys.executable, "-m", "manigraph_shared.cli", "planner", *argv],
            capture_output=True,
            text=True,
            timeout=60,
            check=False,
        )
        assert result.returncode != 0, argv
        assert "cells" in result.stderr, (argv, result.stderr)


class StallingPolicy(Policy):
    """The expert, except that a scene of episode ``stuck`` blocks ``decide`` until released:
    a cell whose decision takes as long as the test wants."""

    name = "stalling-expert"

    def __init__(self) -> None:
        self.expert = ExpertPolicy()
        self.release = threading.Event()
        self.stuck = threading.Event()

    def decide(self, scene: Scene) -> Decision | None:
        if scene.episode_id == "stuck":
            self.stuck.set()
            self.release.wait(30.0)
        return self.expert.decide(scene)


def test_a_cell_stuck_in_a_decision_delays_no_other_cell(running_stack: Stack) -> None:
    running_stack.start("router")
    policy = StallingPolicy()
    with running_stack.client() as planner_bus:
        served = CellServices(
            planner_bus,
            lambda bus, _cell: PlannerService(bus, policy, decide_on_arrival=False),
            ["slow", "fast"],
        )
        served.start()
        try:
            with cell_buses(running_stack, "slow", "fast") as buses:
                for bus in buses.values():
                    running_stack.wait_alive(bus, "planner")
                actions = {cell: Actions(bus) for cell, bus in buses.items()}
                buses["slow"].publish(two_block_scene("stuck", time.time(), 0))
                assert policy.stuck.wait(30.0), "the slow cell's planner never decided"
                waits = drive(buses["fast"], actions["fast"], "ep-fast", decisions=3, timeout=10.0)
                assert actions["slow"].ids() == []  # still deciding, and the fast cell went on
                assert max(waits) < 10.0
                policy.release.set()
                assert actions["slow"].wait_for("stuck:0", 10.0).episode_id == "stuck"
        finally:
            policy.release.set()
            served.stop()
            served.wait()
            served.close()
    assert not served.failures
