"""Defence in depth: each forged-message attack of issue 16 against real services on loopback.

Every attack here is sent by a client that may publish anything (what the router's access
control refuses is tested elsewhere): the services themselves must refuse it, count it, and
keep working for the real stack.
"""

from __future__ import annotations

import json
import threading
import time

import pytest
from reliability_helpers import (
    STARTUP,
    Inbox,
    action,
    rejections,
    reset,
    scene_of,
    start,
    top_block_and_free_goal,
)

from manigraph_shared.messages import (
    Action,
    EpisodeEvent,
    EpisodePhase,
    EpisodeRequest,
    GripperOp,
    RobotCommand,
    RobotFeedback,
    Scene,
    ServiceStatus,
    SkillState,
    SkillStatus,
    Vector3,
)
from manigraph_testkit.testing import Stack

pytestmark = pytest.mark.integration


def test_forged_scenes_are_refused_and_never_reach_the_skill(running_stack: Stack) -> None:
    """A Scene with a huge sequence (or of another episode) poisoned the skills' scene cache:
    the next placement went to the forger's goal position. Now it is refused and counted."""
    start(running_stack, "sim", "skills")
    with running_stack.client() as bus:
        running_stack.wait_alive(bus, "sim", "skills", timeout=STARTUP)
        scenes, statuses = Inbox(bus, Scene), Inbox(bus, ServiceStatus)
        skill = Inbox(bus, SkillStatus)
        time.sleep(0.3)
        reset(bus, "forged-scene")
        real = scene_of(scenes, "forged-scene")
        block, goal = top_block_and_free_goal(real)
        moved = [
            g.replace(position=Vector3(x=0.6, y=0.45, z=0.02)) if g.id == goal else g
            for g in real.goals
        ]
        huge = real.replace(sequence=10**15, goals=moved)
        bus.publish(huge)
        bus.publish(real.replace(episode_id="someone-else", sequence=1))
        assert rejections(statuses, "skills", "Scene:sequence_jump") >= 1
        assert rejections(statuses, "skills", "Scene:not_running_episode") >= 1

        bus.publish(action(real, block, goal, "forged-scene:0"))
        final = skill.wait(lambda s: s.decision_id == "forged-scene:0" and s.state.terminal)
        assert final.state is SkillState.SUCCEEDED, final
        after = scenes.wait(lambda s: s.episode_id == "forged-scene" and s.stamp > final.stamp)
        placed = after.object(block).position
        target = real.goal(goal).position
        assert abs(placed.x - target.x) < 0.01 and abs(placed.y - target.y) < 0.01  # not 0.6, 0.45
        assert after.goal(goal).filled


def test_sixty_forged_actions_do_not_stall_a_real_run(running_stack: Stack) -> None:
    """60 forged Actions made `manigraph run --timeout 30` fail (skills waited 2 s on each
    on its only thread). Now the queue is bounded, the overflow refused, nothing waits on the
    receiving thread, and the real run completes within its timeout."""
    start(running_stack, "sim", "planner", "skills")
    with running_stack.client() as bus:
        running_stack.wait_alive(bus, "sim", "planner", "skills", timeout=STARTUP)
        statuses = Inbox(bus, ServiceStatus)
        forged_ids: list[str] = []
        started = threading.Event()

        def flood(event: EpisodeEvent) -> None:
            if event.phase is not EpisodePhase.START or started.is_set():
                return
            started.set()
            for index in range(60):
                episode = event.episode_id if index % 2 else f"ghost-{index}"
                forged = Action(
                    decision_id=f"forged-{index}",
                    episode_id=episode,
                    scene_sequence=index % 3 * 10**9,
                    object_id="no_such_block",
                    goal_id="goal_0",
                    policy="attacker",
                    stamp=time.time(),
                )
                forged_ids.append(forged.decision_id)
                bus.publish(forged)

        bus.subscribe(EpisodeEvent, flood)
        time.sleep(0.3)
        result = running_stack.run(
            "run", "--blocks", "4", "--episodes", "2", "--timeout", "30", timeout=90
        )
        assert result.returncode == 0, result.stderr[-3000:]
        summary = json.loads(result.stdout.strip().splitlines()[-1])
        assert summary["success_rate"] == 1.0, summary
        assert len(forged_ids) == 60
        status: ServiceStatus = statuses.wait(
            lambda s: s.service == "skills" and s.messages_rejected >= 30, timeout=5.0
        )
        refused = {kind for kind in status.rejections if kind.startswith("Action:")}
        assert "Action:not_running_episode" in refused, status.rejections


def test_an_action_that_overtakes_its_episodes_start_is_executed(running_stack: Stack) -> None:
    """The planner is one hop nearer to skills than the world's start event: the first action
    of a new episode can arrive first. Skills refused it (``not_running_episode``) and the
    planner decided again on the next scene, so a run over Zenoh took another path than the
    same seed in process. Between episodes it now waits for the episode; a ghost's never
    comes, and it is refused."""
    start(running_stack, "sim", "skills")
    with running_stack.client() as bus:
        running_stack.wait_alive(bus, "sim", "skills", timeout=STARTUP)
        scenes, skill = Inbox(bus, Scene), Inbox(bus, SkillStatus)
        time.sleep(0.3)
        first = reset(bus, "first")
        earlier = scene_of(scenes, "first")
        bus.publish(first.replace(phase=EpisodePhase.END, success=False))
        time.sleep(0.2)  # skills has seen the end of "first" and nothing of "next"
        block, goal = top_block_and_free_goal(earlier)  # seed 0 again: the same layout
        # A decision of the ended episode (made on a scene just before its end) moves nothing:
        # begun after the end, it once ran in the next episode's world.
        bus.publish(action(earlier, block, goal, "first:1"))
        late = skill.wait(lambda s: s.decision_id == "first:1" and s.state.terminal)
        assert (late.state, late.reason) == (SkillState.FAILED, "episode_ended")
        ahead = action(earlier, block, goal, "next:0", episode_id="next")
        ahead = ahead.replace(scene_sequence=earlier.sequence + 1)
        bus.publish(ahead)
        reset(bus, "next")
        done = skill.wait(lambda s: s.decision_id == "next:0" and s.state.terminal)
        assert done.state is SkillState.SUCCEEDED, done

        bus.publish(action(earlier, block, goal, "ghost:0", episode_id="ghost"))
        ghost = skill.wait(lambda s: s.decision_id == "ghost:0" and s.state.terminal)
        assert (ghost.state, ghost.reason) == (SkillState.FAILED, "not_running_episode")


def test_a_scene_that_overtakes_its_episodes_start_is_decided_on(running_stack: Stack) -> None:
    """Scenes and episode events travel by different keys: the next episode's first scene can
    reach the planner before the end of the running episode and its own start. The planner
    refused it (``not_running_episode``) and waited for a scene that never came; a replayed
    log then went out of step and reported decisions that differed from the recorded ones.
    Now the gate keeps it, and the planner decides on it once the events arrive."""
    start(running_stack, "sim", "planner")
    with running_stack.client() as bus:
        running_stack.wait_alive(bus, "sim", "planner", timeout=STARTUP)
        scenes, actions = Inbox(bus, Scene), Inbox(bus, Action)
        time.sleep(0.3)
        first = reset(bus, "first")
        actions.wait(lambda a: a.decision_id == "first:0", timeout=STARTUP)
        earlier = scene_of(scenes, "first")
        ahead = earlier.replace(episode_id="next", sequence=1, stamp=time.time())
        bus.publish(ahead)
        time.sleep(0.5)  # the planner has refused it: "first" is still running
        now = time.time()
        ended = {"phase": EpisodePhase.END, "success": False, "stamp": now}
        bus.publish(first.replace(**ended))
        bus.publish(first.replace(episode_id="next", stamp=now))
        decided = actions.wait(lambda a: a.episode_id == "next", timeout=10.0)
        assert (decided.decision_id, decided.scene_sequence) == ("next:0", 1)


def test_ids_at_the_64_character_limit_complete(running_stack: Stack) -> None:
    """Skills built command ids by appending a counter to the decision id: a valid 64-char id
    became an invalid 66-char one and the episode never ended. Now ids are derived to fit."""
    start(running_stack, "sim", "planner", "skills")
    with running_stack.client() as bus:
        running_stack.wait_alive(bus, "sim", "planner", "skills", timeout=STARTUP)
        ends = Inbox(bus, EpisodeEvent)
        time.sleep(0.3)
        episode_id = "e" * 64  # the planner's <episode>:<step> would be 66 characters
        bus.request(
            EpisodeRequest(episode_id=episode_id, task="stack", blocks=3, seed=1),
            EpisodeEvent,
            timeout=20.0,
        )
        end: EpisodeEvent = ends.wait(
            lambda e: e.episode_id == episode_id and e.phase is EpisodePhase.END, timeout=30.0
        )
        assert end.success, end


def test_a_64_character_decision_id_is_executed(running_stack: Stack) -> None:
    start(running_stack, "sim", "skills")
    with running_stack.client() as bus:
        running_stack.wait_alive(bus, "sim", "skills", timeout=STARTUP)
        scenes, skill = Inbox(bus, Scene), Inbox(bus, SkillStatus)
        time.sleep(0.3)
        reset(bus, "long-ids")
        real = scene_of(scenes, "long-ids")
        decision_id = "d" * 64
        bus.publish(action(real, *top_block_and_free_goal(real), decision_id))
        final = skill.wait(lambda s: s.decision_id == decision_id and s.state.terminal)
        assert final.state is SkillState.SUCCEEDED, final


def test_forged_picks_of_nothing_do_not_spend_the_step_budget(running_stack: Stack) -> None:
    """13 forged picks of a nonexistent object used up an episode's step budget (2 K + 4 =
    12 for K = 4). Now they are refused before they are counted, and the real episode
    succeeds afterwards in its usual handful of steps."""
    start(running_stack, "sim", "skills")
    with running_stack.client() as bus:
        running_stack.wait_alive(bus, "sim", "skills", timeout=STARTUP)
        scenes, feedback = Inbox(bus, Scene), Inbox(bus, RobotFeedback)
        skill, ends = Inbox(bus, SkillStatus), Inbox(bus, EpisodeEvent)
        time.sleep(0.3)
        reset(bus, "ghost-picks")
        real = scene_of(scenes, "ghost-picks")
        for index in range(13):  # straight to the sim, as a forged robot driver would
            bus.publish(
                RobotCommand(
                    command_id=f"ghost-{index}",
                    decision_id=f"ghost-picks:{100 + index}",
                    op=GripperOp.PICK,
                    object_id="ghost_block",
                    position=Vector3(x=0.5, y=0.0, z=0.02),
                    stamp=time.time(),
                )
            )
            bus.publish(action(real, "ghost_block", "goal_0", f"ghost-picks:{200 + index}"))
        answer: RobotFeedback = feedback.wait(lambda f: f.command_id == "ghost-12")
        assert not answer.ok and answer.reason == "unknown_object"
        refused = skill.wait(lambda s: s.decision_id == "ghost-picks:212" and s.state.terminal)
        assert refused.reason in ("unknown_object", "skills_busy")  # a burst overflows the queue
        running_stack.start("planner", "planner")
        end: EpisodeEvent = ends.wait(
            lambda e: e.episode_id == "ghost-picks" and e.phase is EpisodePhase.END, timeout=STARTUP
        )
        assert end.success, end
        assert end.steps <= 4, end  # the forged picks were not counted


def test_robot_commands_outside_the_workspace_are_refused(running_stack: Stack) -> None:
    """A forged RobotCommand put a block 55 m away: the sim now refuses it, with a reason."""
    start(running_stack, "sim")
    with running_stack.client() as bus:
        running_stack.wait_alive(bus, "sim", timeout=STARTUP)
        scenes, feedback = Inbox(bus, Scene), Inbox(bus, RobotFeedback)
        statuses = Inbox(bus, ServiceStatus)
        time.sleep(0.3)
        reset(bus, "far-away")
        real = scene_of(scenes, "far-away")
        block, _goal = top_block_and_free_goal(real)

        def command(command_id: str, op: GripperOp, where: Vector3) -> RobotFeedback:
            bus.publish(
                RobotCommand(
                    command_id=command_id,
                    decision_id="far-away:0",
                    op=op,
                    object_id=block,
                    position=where,
                    stamp=time.time(),
                )
            )
            return feedback.wait(lambda f: f.command_id == command_id)

        outside = command("far-pick", GripperOp.PICK, Vector3(x=55.0, y=0.0, z=0.02))
        assert not outside.ok and outside.reason == "outside_workspace"
        assert command("pick", GripperOp.PICK, real.object(block).position).ok
        outside = command("far-place", GripperOp.PLACE, Vector3(x=55.0, y=0.0, z=0.02))
        assert not outside.ok and outside.reason == "outside_workspace"
        below = command("under-table", GripperOp.PLACE, Vector3(x=0.5, y=0.0, z=-3.0))
        assert not below.ok and below.reason == "outside_workspace"
        time.sleep(0.2)
        after = scenes.wait(lambda s: s.episode_id == "far-away" and s.stamp > time.time() - 0.1)
        assert all(abs(o.position.x) < 1.0 for o in after.objects)
        assert rejections(statuses, "sim", "RobotCommand:outside_workspace") == 3
