"""The defence-in-depth pieces on their own (no network): the scene gate, derived ids, the
planner giving up a lost decision, bounded inbox and refusal counters."""

from __future__ import annotations

import time

import pytest

from manigraph_planner.decisions import DecisionMaker
from manigraph_planner.policies import load_policy
from manigraph_shared.bus import Bus
from manigraph_shared.ids import derived_id
from manigraph_shared.messages import (
    Action,
    EpisodeEvent,
    EpisodePhase,
    Scene,
    SceneGoal,
    SceneObject,
    Vector3,
)
from manigraph_shared.scene_gate import SceneGate, SceneLimits
from manigraph_shared.service import Rejections, Service

BLOCK = Vector3(x=0.04, y=0.04, z=0.04)


def scene(episode: str, sequence: int, stamp: float = 100.0) -> Scene:
    return Scene(
        episode_id=episode,
        stamp=stamp,
        sequence=sequence,
        objects=[
            SceneObject(
                id="b0", category="block", position=Vector3(x=0.5, y=-0.2, z=0.02), size=BLOCK
            )
        ],
        goals=[SceneGoal(id="g0", category="block", position=Vector3(x=0.5, y=0.2, z=0.02))],
    )


def event(episode: str, phase: EpisodePhase) -> EpisodeEvent:
    return EpisodeEvent(
        episode_id=episode,
        phase=phase,
        task="stack",
        seed=0,
        goals_total=1,
        goals_filled=0,
        success=None if phase is EpisodePhase.START else False,
        stamp=1.0,
    )


def test_the_gate_refuses_jumps_other_episodes_and_the_future() -> None:
    gate = SceneGate(SceneLimits(max_sequence_jump=100, max_stamp_jump=10.0), clock=lambda: 200.0)
    gate.on_episode(event("e1", EpisodePhase.START))
    assert gate.check(scene("e1", 5)) is None
    assert gate.check(scene("e1", 5 + 101)) == "sequence_jump"
    assert gate.check(scene("e1", 6, stamp=111.0)) == "stamp_jump"
    assert gate.check(scene("e1", 6, stamp=261.0)) == "stamp_in_future"
    assert gate.check(scene("forger", 7)) == "not_running_episode"
    assert gate.check(scene("e1", 4)) is None  # older, overtaken: the cache keeps the newest
    assert gate.check(scene("e1", 105)) is None  # within the jump of the newest accepted (5)
    assert gate.is_running("e1") and not gate.is_running("forger")


def test_between_episodes_the_next_one_is_accepted_before_its_start_event() -> None:
    gate = SceneGate()
    gate.on_episode(event("e1", EpisodePhase.START))
    assert gate.check(scene("e1", 1)) is None
    assert gate.check(scene("e2", 2)) == "not_running_episode"  # e1 still runs
    assert not gate.may_be_next("e2")
    gate.on_episode(event("e1", EpisodePhase.END))
    assert gate.may_be_next("e2") and not gate.is_running("e2")  # an action may come first
    assert gate.check(scene("e2", 3)) is None  # overtook its start event
    gate.on_episode(event("e2", EpisodePhase.START))
    assert gate.check(scene("e2", 4)) is None
    assert gate.check(scene("e1", 5)) == "not_running_episode"
    assert not gate.has_ended("e2") and not gate.has_ended("e1")  # e1's end is past
    gate.on_episode(event("e2", EpisodePhase.END))
    assert gate.has_ended("e2")  # an action of it that comes now is refused


def test_a_scene_refused_before_its_episode_events_is_handed_back_by_them() -> None:
    gate = SceneGate()
    gate.on_episode(event("e1", EpisodePhase.START))
    assert gate.check(scene("e2", 2)) == "not_running_episode"  # overtook "e1" ending
    assert gate.check(scene("e2", 1)) == "not_running_episode"  # older: the newer is kept
    assert [s.sequence for s in gate.on_episode(event("e1", EpisodePhase.END))] == [2]
    assert gate.on_episode(event("e1", EpisodePhase.END)) == []  # handed back once
    gate.on_episode(event("e2", EpisodePhase.START))
    assert gate.check(scene("e3", 5)) == "not_running_episode"  # overtook its own start
    assert [s.episode_id for s in gate.on_episode(event("e3", EpisodePhase.START))] == ["e3"]
    for index in range(100):  # a forger's episodes: only the last few are kept
        gate.check(scene(f"forged{index}", 1))
    handed = gate.on_episode(event("e3", EpisodePhase.END))
    assert [s.episode_id for s in handed] == ["forged98", "forged99"]


def test_without_episode_events_the_gate_follows_the_scenes() -> None:
    gate = SceneGate()  # a service started mid-episode has nothing better to go by
    assert gate.check(scene("e1", 10)) is None
    assert gate.check(scene("e1", 10**12)) == "sequence_jump"


@pytest.mark.parametrize("length", [1, 40, 62, 63, 64])
def test_derived_ids_stay_valid_and_distinct_for_any_valid_base(length: int) -> None:
    base = "a" * length
    ids = {derived_id(base, ".", str(n)) for n in range(1000)}
    assert len(ids) == 1000
    for made in ids:
        assert len(made) <= 64
        Action(
            decision_id=made,
            episode_id=made,
            scene_sequence=0,
            object_id="b",
            goal_id="g",
            policy="p",
            stamp=0.0,
        )
    # Bases that differ only past the kept prefix still give different ids (the hash).
    assert derived_id("a" * 63 + "b", ".", "0") != derived_id("a" * 63 + "c", ".", "0")
    if length <= 62:
        assert derived_id(base, ".", "0") == f"{base}.0"  # readable whenever it fits


def test_the_planner_gives_up_a_decision_whose_skill_never_reports() -> None:
    decisions = DecisionMaker(load_policy("expert"), decision_timeout=5.0)
    first = decisions.on_scene(scene("e1", 1, stamp=time.time()))
    assert first is not None and decisions.pending == first.decision_id
    assert decisions.on_scene(scene("e1", 2, stamp=time.time())) is None  # waits for it
    assert decisions.give_up(decisions.pending_since + 1.0) is None
    assert decisions.give_up(decisions.pending_since + 5.0) == "skill_timeout"
    again = decisions.on_scene(scene("e1", 3, stamp=time.time() + 0.1))
    assert again is not None and again.decision_id != first.decision_id
    assert decisions.give_up(time.monotonic(), skills_alive=False) == "skills_lost"


def test_the_planner_decides_nothing_while_stopped() -> None:
    decisions = DecisionMaker(load_policy("expert"))
    decisions.on_stop(True)
    assert decisions.on_scene(scene("e1", 1, stamp=time.time())) is None
    decisions.on_stop(False)
    assert decisions.on_scene(scene("e1", 2, stamp=time.time())) is not None


def test_refusals_are_counted_by_kind_and_bounded_in_kinds() -> None:
    counts = Rejections()
    assert counts.add("Scene:sequence_jump") is True  # logged the first time
    assert counts.add("Scene:sequence_jump") is False  # then at most once a second
    for index in range(200):
        counts.add(f"Action:reason_{index}")
    snapshot = counts.snapshot()
    assert snapshot["Scene:sequence_jump"] == 2
    assert len(snapshot) <= 64 and snapshot["other"] > 0
    assert counts.total == 202


class _Quiet(Service):
    name = "quiet"


def test_a_refused_message_is_counted_by_type_and_reason() -> None:
    service = _Quiet(bus=None)  # type: ignore[arg-type]  (never touches the bus here)
    service.reject(Bus.__name__, "inbox_full")
    service.reject(Bus.__name__, "inbox_full")
    assert service.rejections.snapshot() == {"Bus:inbox_full": 2}
    assert service.messages_rejected == 2
