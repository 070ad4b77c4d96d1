"""Refusals remembered within an episode (manigraph_planner.refusals, issue 51 item 1)."""

from __future__ import annotations

import math

import msgspec
import pytest
from test_recovery import Preferences, finished, obj, scene, slot

from manigraph_planner.decisions import DecisionMaker, OutOfOptions
from manigraph_planner.refusals import RefusalMemory, scope_of
from manigraph_shared.decision_failure import OUT_OF_OPTIONS, cannot_decide
from manigraph_shared.messages import Action, Quaternion, ServiceState, ServiceStatus

GOALS = [slot("g0", 0.3, 0), slot("g1", 0.3, 1)]


def world(**x: float) -> tuple[list, list]:
    """Blocks on the table at the given x (a and b, and c far away)."""
    at = {"a": 0.5, "b": 0.7, "c": 1.2} | x
    return [obj(name, at[name], 0) for name in sorted(at)], GOALS


class Episode:
    """A DecisionMaker fed one scene per step, each skill ending with the reason given."""

    def __init__(self, *pairs: tuple[str, str]) -> None:
        self.maker = DecisionMaker(Preferences(*pairs))
        self.t = 0.0

    def step(self, objects_goals: tuple[list, list], reason: str | None) -> Action:
        self.t += 10.0
        action = self.maker.on_scene(scene(*objects_goals, stamp=self.t, seq=int(self.t)))
        assert action is not None
        self.maker.on_status(finished(action, self.t + 1.0, reason))
        return action


def test_every_reason_the_skills_emit_is_classified() -> None:
    for reason in ("skills_busy", "not_running_episode", "stopped", "robot_lost", "episode_ended"):
        assert scope_of(reason) == "transient"
    assert scope_of("object_covered") == "object"
    assert scope_of("slot_taken") == "goal"
    assert scope_of("no_ik_solution") == scope_of("a_reason_nobody_emits_yet") == "pair"


def test_a_refused_pair_is_not_asked_again_while_only_far_objects_move() -> None:
    episode = Episode(("a", "g0"), ("b", "g0"))
    first = episode.step(world(), "collision")
    second = episode.step(world(c=1.3), None)  # c moved: far from a and g0
    assert (first.object_id, first.recovery) == ("a", None)
    assert (second.object_id, second.recovery, second.passed_over) == (
        "b",
        "refused",
        "a->g0: collision",
    )
    third = episode.step(world(c=1.4, b=0.55), None)  # b set down beside a: ask again
    # asked again (b, chosen since with no goal filled, is passed over as a repeat)
    assert (third.object_id, third.rank, third.passed_over) == ("a", 0, None)


def test_a_reach_refusal_ignores_neighbours_and_stands_until_the_object_moves() -> None:
    episode = Episode(("a", "g0"), ("b", "g1"))
    episode.step(world(), "no_ik_solution")
    assert episode.step(world(b=0.55), None).object_id == "b"  # a neighbour moved: still no
    assert episode.step(world(b=0.55, a=0.45), None).object_id == "a"  # a moved: ask again


def test_a_transient_refusal_is_asked_again_at_once() -> None:
    episode = Episode(("a", "g0"), ("b", "g0"))
    episode.step(world(), "skills_busy")
    again = episode.step(world(), None)
    assert (again.object_id, again.rank, again.recovery) == ("a", 0, None)


def test_a_covered_object_is_passed_over_with_every_goal_and_so_are_others_covered() -> None:
    tower = ([obj("a", 0.5, 0), obj("b", 0.5, 1), obj("c", 0.5, 2), obj("d", 0.8, 0)], GOALS)
    episode = Episode(("a", "g0"), ("a", "g1"), ("b", "g0"), ("c", "g0"), ("d", "g0"))
    first = episode.step(tower, "object_covered")
    nxt = episode.step(tower, None)
    # not a's other goal, nor b (covered too, never asked): c, the top of the tower
    assert (first.object_id, nxt.object_id, nxt.recovery) == ("a", "c", "refused")


def test_out_of_options_ends_the_episode_naming_its_refusals() -> None:
    episode = Episode(("a", "g0"), ("b", "g0"))
    episode.step(world(), "no_ik_solution")
    episode.step(world(), "collision")
    with pytest.raises(OutOfOptions) as raised:
        episode.maker.on_scene(scene(*world(), stamp=100.0, seq=100))
    assert raised.value.why.startswith(OUT_OF_OPTIONS)
    assert "no_ik_solution x1" in raised.value.why and "collision x1" in raised.value.why
    assert episode.maker.on_scene(scene(*world(), stamp=110.0, seq=110)) is None  # ended
    status = ServiceStatus(
        service="planner", state=ServiceState.ERROR, detail=str(raised.value), stamp=1.0
    )
    assert cannot_decide(status) == ("e", raised.value.why)


def test_a_world_that_only_made_no_progress_still_takes_the_first_choice_again() -> None:
    episode = Episode(("a", "g0"), ("b", "g0"))
    actions = [episode.step(world(), None) for _ in range(3)]
    assert [(a.object_id, a.recovery) for a in actions] == [
        ("a", None),
        ("b", "no_progress"),
        ("a", "exhausted"),
    ]


def test_bad_memory_settings_are_refused() -> None:
    with pytest.raises(ValueError, match="radius"):
        RefusalMemory(radius=-1)
    with pytest.raises(ValueError, match="tolerance"):
        RefusalMemory(tolerance=-0.1)


def test_an_action_names_the_refusal_it_passes_over_and_old_logs_decode() -> None:
    action = Episode(("a", "g0")).step(world(), None)
    named = Action.decode(action.replace(passed_over="a->g0: no_ik_solution").encode())
    assert named.passed_over == "a->g0: no_ik_solution"
    assert Action.decode(action.encode()).passed_over is None


def test_a_reach_refusal_stands_while_a_measured_pose_jitters_and_ends_once_it_turns() -> None:
    def turned(degrees: float) -> tuple[list, list]:
        objects, goals = world()
        half = math.radians(degrees) / 2
        quaternion = Quaternion(z=math.sin(half), w=math.cos(half))
        objects[0] = msgspec.structs.replace(objects[0], orientation=quaternion)  # a
        return objects, goals

    episode = Episode(("a", "g0"), ("b", "g1"))
    episode.step(turned(0.0), "no_ik_solution")
    assert episode.step(turned(2.0), None).object_id == "b"  # RGB-D jitter: still no
    assert episode.step(turned(30.0), None).object_id == "a"  # turned: ask again
