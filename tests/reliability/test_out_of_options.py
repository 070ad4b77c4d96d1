"""A planner out of options ends that episode, naming its refusals; the run goes on."""

from __future__ import annotations

import json
import threading
import time

from test_loud_failures import stand_in_stack, started

from manigraph_planner.decisions import OutOfOptions
from manigraph_shared.bus import Bus
from manigraph_shared.messages import (
    Action,
    EpisodeEvent,
    EpisodeRequest,
    ServiceStatus,
    SkillStatus,
)
from manigraph_testkit.testing import Stack


def test_an_episode_out_of_options_ends_alone_and_its_refusals_are_counted(
    running_stack: Stack,
) -> None:
    why = "out_of_options: 1 refusals stand (no_ik_solution x1)"
    holder: dict[str, Bus] = {}

    def reset(request: EpisodeRequest) -> EpisodeEvent:
        # What a real stack does after the reset's answer (the planner decides on the first
        # scene, skills refuses, the planner runs out of options): published once the answer
        # is out, so the run client has started the episode before it hears of it.
        threading.Timer(0.3, refuse, (request.episode_id,)).start()
        return started(request)

    def refuse(episode: str) -> None:
        bus = holder["bus"]
        decision = f"{episode}:0"
        bus.publish(
            Action(
                decision_id=decision,
                episode_id=episode,
                scene_sequence=1,
                object_id="bowl_1",
                goal_id="top_bowl_07",
                policy="p",
                stamp=1.0,
            )
        )
        time.sleep(0.1)  # skills answers after the Action reached everyone
        bus.publish(
            SkillStatus(
                decision_id=decision,
                skill="pick_and_place",
                state="failed",
                reason="no_ik_solution",
                stamp=1.0,
            )
        )
        time.sleep(0.2)  # the planner says it is out of options after it heard the refusal
        refusal = OutOfOptions(episode, why)
        bus.publish(ServiceStatus(service="planner", state="error", detail=str(refusal), stamp=1.0))

    with stand_in_stack(running_stack, reset) as services:
        holder["bus"] = services
        result = running_stack.run(
            "run", "--episodes", "2", "--stall-timeout", "30", "-e", running_stack.endpoint
        )
    summary = json.loads(result.stdout.strip().splitlines()[-1])
    assert summary["episodes"] == 2 and "aborted" not in summary, result.stderr
    assert [r["reason"] for r in summary["results"]] == [why, why]
    assert [r["refusals"] for r in summary["results"]] == [{"no_ik_solution": 1}] * 2
    assert summary["refusals"] == {"no_ik_solution": 2}
