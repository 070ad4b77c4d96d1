from __future__ import annotations

from manigraph_shared.messages import EpisodePhase, EpisodeRequest, GripperOp, RobotCommand, Scene
from manigraph_sim.geometric.backend import GeometricBackend


def command(
    op: GripperOp, object_id: str, scene: Scene, goal_id: str | None = None
) -> RobotCommand:
    target = scene.goal(goal_id).position if goal_id else scene.object(object_id).position
    return RobotCommand(
        command_id=f"{op}-{object_id}",
        decision_id="d",
        op=op,
        object_id=object_id,
        position=target,
        stamp=1.0,
    )


def test_an_inverted_stack_ends_the_episode_with_success() -> None:
    sim = GeometricBackend()
    start = sim.reset(EpisodeRequest(episode_id="e1", task="stack", blocks=3, seed=4), 1.0)
    assert start.phase is EpisodePhase.START and start.goals_total == 3
    for top, goal in (("block_2", "goal_0"), ("block_1", "goal_1"), ("block_0", "goal_2")):
        scene = sim.scene(2.0)
        assert scene is not None
        assert sim.execute(command(GripperOp.PICK, top, scene), 2.0).ok
        assert sim.execute(command(GripperOp.PLACE, top, scene, goal), 2.0).ok
    end = sim.end_event(3.0)
    assert end is not None and end.success and end.goals_filled == 3 and end.steps == 3
    assert sim.end_event(3.0) is None  # reported once
    final = sim.scene(4.0)
    assert final is not None and all(g.filled for g in final.goals)
    assert final.episode_ended
    assert all(o.filled for o in final.objects)


def test_failed_picks_spend_the_step_budget() -> None:
    sim = GeometricBackend()
    sim.reset(EpisodeRequest(episode_id="e2", task="stack", blocks=2, seed=0, max_steps=3), 1.0)
    scene = sim.scene(1.0)
    assert scene is not None
    for _ in range(3):
        feedback = sim.execute(command(GripperOp.PICK, "block_0", scene), 1.0)
        assert not feedback.ok and feedback.reason == "object_covered"
    end = sim.end_event(2.0)
    assert end is not None and end.success is False and "budget" in end.reason


def test_scene_sequence_increases_and_positions_match_the_seed() -> None:
    a, b = GeometricBackend(), GeometricBackend()
    request = EpisodeRequest(episode_id="e3", task="stack", blocks=4, seed=11)
    a.reset(request, 1.0)
    b.reset(request, 1.0)
    first, second = a.scene(1.0), a.scene(1.1)
    assert first is not None and second is not None
    assert second.sequence == first.sequence + 1
    assert first.objects == b.scene(1.0).objects  # type: ignore[union-attr]
