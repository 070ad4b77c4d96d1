"""A run's refusal count (``EpisodeProgress``, issue 51): a decision the planner made on the
finished scene, refused ``episode_ended`` once the world had ended the episode, is not a
refusal of the episode; the last decision's own refusal after the end still is."""

from __future__ import annotations

from collections.abc import Callable

from manigraph_shared.messages import Action, EpisodeEvent, SkillStatus
from manigraph_tools.episodes import EpisodeProgress


class FakeBus:
    def __init__(self) -> None:
        self.handlers: dict[type, Callable] = {}

    def subscribe(self, kind: type, handler: Callable, key: str | None = None) -> None:
        self.handlers[kind] = handler

    def publish(self, message: object) -> None:
        self.handlers[type(message)](message)


def action(step: int) -> Action:
    return Action(
        decision_id=f"e:{step}",
        episode_id="e",
        scene_sequence=step,
        object_id="a",
        goal_id="g",
        policy="p",
        stamp=1.0,
    )


def failed(step: int, reason: str) -> SkillStatus:
    return SkillStatus(decision_id=f"e:{step}", skill="p", state="failed", reason=reason, stamp=2)


END = EpisodeEvent(
    episode_id="e",
    phase="end",
    task="stack",
    seed=0,
    goals_total=1,
    goals_filled=1,
    stamp=3,
    success=True,
    reason="all goals filled",
)


def test_a_decision_on_the_finished_scene_is_not_a_refusal_of_the_episode() -> None:
    bus = FakeBus()
    progress = EpisodeProgress(bus)
    progress.start("e")
    bus.publish(action(0))
    bus.publish(failed(0, "collision"))
    bus.publish(action(1))  # decided on the finished scene before the end event came
    bus.publish(END)
    bus.publish(failed(1, "episode_ended"))
    bus.publish(action(2))  # after the end event
    bus.publish(failed(2, "no_ik_solution"))
    assert progress.refusals() == {"collision": 1}


def test_the_last_decisions_refusal_after_the_end_still_counts() -> None:
    bus = FakeBus()
    progress = EpisodeProgress(bus)
    progress.start("e")
    bus.publish(action(0))
    bus.publish(END)  # the step budget spent by this decision: its status comes after
    bus.publish(failed(0, "no_ik_solution"))
    assert progress.refusals() == {"no_ik_solution": 1}
