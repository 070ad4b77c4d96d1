"""Actions forged for episodes that never start cost the next real episode nothing: the
skills service refuses them as that episode starts, rather than holding its worker for a
second on each (200 of them delayed the next episode by 3.5 s)."""

from __future__ import annotations

import sys
import time
from pathlib import Path

import pytest

from manigraph_shared.messages import Action, Scene, SkillState, SkillStatus
from manigraph_testkit.testing import Stack

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "reliability"))
from reliability_helpers import (
    STARTUP,
    Inbox,
    action,
    reset,
    scene_of,
    start,
    top_block_and_free_goal,
)

pytestmark = pytest.mark.integration

FORGED = 200


def forged(index: int) -> Action:
    return Action(
        decision_id=f"forged-{index}",
        episode_id=f"ghost-{index}",
        scene_sequence=0,
        object_id="block_0",
        goal_id="goal_0",
        policy="attacker",
        stamp=time.time(),
    )


def terminal_of_forged(skill: Inbox, timeout: float = 10.0) -> dict[str, tuple[object, object]]:
    """Each forged action's final status (all of them, or AssertionError after ``timeout``)."""
    deadline = time.monotonic() + timeout
    while True:
        final = {
            s.decision_id: (s.state, s.reason)
            for s in list(skill.seen)
            if isinstance(s, SkillStatus)
            and s.decision_id.startswith("forged-")
            and s.state.terminal
        }
        if len(final) == FORGED:
            return final
        if time.monotonic() > deadline:
            raise AssertionError(f"{FORGED - len(final)} forged actions never answered")
        time.sleep(0.05)


def test_actions_of_unknown_episodes_are_refused_when_a_real_one_starts(
    running_stack: Stack,
) -> None:
    start(running_stack, "sim", "skills")
    with running_stack.client() as bus:
        running_stack.wait_alive(bus, "sim", "skills", timeout=STARTUP)
        scenes, skill = Inbox(bus, Scene), Inbox(bus, SkillStatus)
        time.sleep(0.3)
        # No episode yet: an action may have overtaken its episode's start, so skills queues
        # what fits (4) and refuses the rest (skills_busy) at once.
        for index in range(FORGED):
            bus.publish(forged(index))
        reset(bus, "real")
        scene = scene_of(scenes, "real")
        time.sleep(0.2)  # skills has the start of "real" (another path than this client's)
        block, goal = top_block_and_free_goal(scene)
        bus.publish(action(scene, block, goal, "real:0"))
        done = skill.wait(lambda s: s.decision_id == "real:0" and s.state.terminal, timeout=30)
        assert done.state is SkillState.SUCCEEDED, done  # not refused skills_busy
        refused = terminal_of_forged(skill)
        assert {state for state, _ in refused.values()} == {SkillState.FAILED}
        reasons = {reason for _, reason in refused.values()}
        assert reasons <= {"skills_busy", "not_running_episode"}, reasons
        assert "not_running_episode" in reasons  # the queued ones, refused at the start
