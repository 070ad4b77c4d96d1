"""The demonstration page's logic without bus or browser: which clicks become actions, and
which steps a demonstration keeps. Scenes and episode events come from the real geometric sim."""

from __future__ import annotations

import http.client
import json
import math
import threading
import time
from collections.abc import Iterator
from pathlib import Path

import pytest

from manigraph_shared.demonstrations import DemonstrationLog
from manigraph_shared.messages import (
    Action,
    EpisodeEvent,
    EpisodePhase,
    EpisodeRequest,
    Quaternion,
    Scene,
    SceneGoal,
    SceneObject,
    SkillState,
    SkillStatus,
    Vector3,
)
from manigraph_shared.orientations import UPRIGHT, UPSIDE_DOWN, nearest_orientation
from manigraph_sim.geometric.backend import GeometricBackend
from manigraph_tools.click_page.clicks import Click, ClickRefused
from manigraph_tools.click_page.http import BadRequest, DemoHttpServer, click_from_json
from manigraph_tools.click_page.scene_view import scene_view, world_extent
from manigraph_tools.click_page.session import DemoSession


class Sink:
    """Collects what the session would write (the file itself: ``DemonstrationLog`` below)."""

    def __init__(self) -> None:
        self.written: list[
            tuple[EpisodeEvent | None, list[tuple[Scene, Action]], EpisodeEvent]
        ] = []

    def write(self, start, steps, end) -> int:  # type: ignore[no-untyped-def]
        self.written.append((start, steps, end))
        return len(steps)


class World:
    """The geometric sim, stamped by a clock the test moves on."""

    def __init__(self, request: EpisodeRequest) -> None:
        self.backend = GeometricBackend()
        self.now = 1000.0
        self.request = request
        self.start = self.backend.reset(request, self.tick())

    def tick(self) -> float:
        self.now += 0.1
        return self.now

    def scene(self) -> Scene:
        scene = self.backend.scene(self.tick())
        assert scene is not None
        return scene

    def status(self, action: Action, state: SkillState, reason: str | None = None) -> SkillStatus:
        return SkillStatus(
            decision_id=action.decision_id,
            skill="pick_and_place",
            state=state,
            reason=reason,
            stamp=self.tick(),
        )

    def end(self, success: bool) -> EpisodeEvent:
        return self.start.replace(phase=EpisodePhase.END, success=success, stamp=self.tick())


def session_on(world: World) -> tuple[DemoSession, Sink]:
    sink = Sink()
    session = DemoSession(lambda: sink, "demos.mcap", clock=world.tick)
    session.expect(world.request)
    session.on_episode(world.start)
    session.on_scene(world.scene())
    return session, sink


def stack_world(seed: int = 0) -> World:
    return World(EpisodeRequest(episode_id="ep-stack", task="stack", blocks=3, seed=seed))


def dish_world() -> World:
    return World(EpisodeRequest(episode_id="ep-dish", task="dishwasher", objects=4, seed=1))


def refusal(session: DemoSession, click: Click) -> str:
    with pytest.raises(ClickRefused) as caught:
        session.act(click)
    return str(caught.value)


def test_a_click_becomes_the_action_the_planner_would_publish() -> None:
    world = stack_world()
    session, _ = session_on(world)
    scene = session.scene
    assert scene is not None and session.busy_reason() is None
    action = session.act(Click("block_2", "goal_0"))
    assert action.decision_id == "ep-stack:0" and action.episode_id == "ep-stack"
    assert action.scene_sequence == scene.sequence
    assert (action.object_id, action.goal_id, action.policy) == ("block_2", "goal_0", "human")
    assert action.orientation_index is None  # blocks: no orientation unless chosen
    assert "busy" in refusal(session, Click("block_1", "goal_1"))  # one decision at a time


def test_bad_clicks_are_refused_with_a_message_and_never_become_actions() -> None:
    world = stack_world()
    session, _ = session_on(world)
    assert "click an object first" in refusal(session, Click(goal_id="goal_0"))
    assert "now click a goal" in refusal(session, Click("block_0"))
    assert "has no ghost" in refusal(session, Click("ghost", "goal_0"))
    assert "no fixture rack_top" in refusal(session, Click("rack_top", family_action="toggle"))
    assert "must be in 0..5" in refusal(session, Click("block_0", "goal_0", orientation_index=6))
    assert session.pending is None and session.step == 0
    said = [m["text"] for m in session.snapshot()["messages"]]  # type: ignore[union-attr]
    assert any("click an object first" in text for text in said)


def test_no_click_before_an_episode_or_while_a_planner_decides() -> None:
    session = DemoSession(Sink, "demos.mcap")
    assert "no episode" in refusal(session, Click("block_0", "goal_0"))
    world = stack_world()
    session, _ = session_on(world)
    session.on_alive("planner", True)
    assert "manigraph up --policy human" in refusal(session, Click("block_2", "goal_0"))
    session.on_alive("planner", False)
    assert session.act(Click("block_2", "goal_0")).object_id == "block_2"


def test_a_refused_step_is_said_and_left_out_and_the_next_click_waits_for_a_fresh_scene() -> None:
    world = stack_world()
    session, sink = session_on(world)
    first = session.act(Click("block_0", "goal_0"))  # the bottom block: the world refuses
    session.on_status(world.status(first, SkillState.ACCEPTED))
    session.on_status(world.status(first, SkillState.FAILED, "object_covered"))
    said = session.snapshot()["messages"][-1]["text"]  # type: ignore[index]
    assert "object_covered" in said and "take what lies on top of it first" in said
    assert session.steps == [] and session.refused == 1
    assert "fresh view" in refusal(session, Click("block_2", "goal_0"))
    session.on_scene(world.scene())
    second = session.act(Click("block_2", "goal_0"))
    assert second.decision_id == "ep-stack:1"
    session.on_status(world.status(second, SkillState.SUCCEEDED))
    assert [a.decision_id for _, a in session.steps] == ["ep-stack:1"]
    assert sink.written == []  # not before the world ends the episode


def test_a_successful_episode_is_written_once_even_when_its_end_overtakes_the_last_status() -> None:
    world = stack_world()
    session, sink = session_on(world)
    action = session.act(Click("block_2", "goal_0"))
    session.on_episode(world.end(success=True))  # the end event first ...
    assert sink.written == []
    session.on_status(world.status(action, SkillState.SUCCEEDED))  # ... then the last status
    ((start, steps, end),) = sink.written
    assert start == world.start and end.success
    assert [(s.sequence, a.decision_id) for s, a in steps] == [
        (action.scene_sequence, "ep-stack:0")
    ]
    assert session.demonstrations == 1
    session.on_episode(world.end(success=True))  # a repeated end event writes nothing more
    assert len(sink.written) == 1
    assert "ended" in refusal(session, Click("block_1", "goal_1"))


def test_a_failed_or_abandoned_episode_is_not_recorded() -> None:
    world = stack_world()
    session, sink = session_on(world)
    action = session.act(Click("block_2", "goal_0"))
    session.on_status(world.status(action, SkillState.SUCCEEDED))
    session.on_episode(world.end(success=False))
    assert sink.written == []
    assert "not recorded" in session.snapshot()["messages"][-1]["text"]  # type: ignore[index]

    world = stack_world(seed=1)
    session, sink = session_on(world)
    action = session.act(Click("block_2", "goal_0"))
    session.on_status(world.status(action, SkillState.SUCCEEDED))
    session.expect(EpisodeRequest(episode_id="ep-next", task="stack", blocks=3))
    assert sink.written == []
    assert "is discarded" in session.snapshot()["messages"][-1]["text"]  # type: ignore[index]


def test_a_decision_without_result_is_given_up() -> None:
    world = stack_world()
    session, _ = session_on(world)
    session.act(Click("block_2", "goal_0"))
    session.tick(time.monotonic() + session.decision_timeout + 1)
    assert session.pending is None and session.refused == 1
    assert "given up" in session.snapshot()["messages"][-1]["text"]  # type: ignore[index]


def test_dishwasher_clicks_carry_the_slot_orientation_unless_one_is_chosen_and_toggle_racks() -> (
    None
):
    world = dish_world()
    session, _ = session_on(world)
    toggle = session.act(Click("rack_top", family_action="toggle"))
    assert (toggle.object_id, toggle.goal_id, toggle.orientation_index) == (
        "rack_top",
        "rack_top",
        None,
    )
    session.on_status(world.status(toggle, SkillState.SUCCEEDED))
    session.on_scene(world.scene())
    bowl = session.act(Click("bowl_0", "top_bowl_03"))
    assert bowl.orientation_index == UPSIDE_DOWN and bowl.family_action is None
    session.on_status(world.status(bowl, SkillState.SUCCEEDED))
    session.on_scene(world.scene())
    plate = session.act(Click("plate_0", "bottom_plate_01", orientation_index=0))
    assert plate.orientation_index == 0  # the person's choice, even a wrong one
    session.on_status(world.status(plate, SkillState.FAILED, "top_rack_open"))
    session.on_scene(world.scene())
    assert "goes to a plate goal" in refusal(session, Click("plate_0", "top_bowl_04"))
    assert session.act(Click("plate_1", "top_plate_02")).orientation_index == UPRIGHT


def test_the_page_sees_each_thing_with_its_extent_along_the_world_axes() -> None:
    world = dish_world()
    view = scene_view(world.scene())
    slots = {g["id"]: g for g in view["goals"]}  # type: ignore[union-attr]
    plate_slot = slots["top_plate_00"]
    assert plate_slot["fixture"] == "rack_top" and plate_slot["orientation"] == UPRIGHT
    assert plate_slot["extent"] == pytest.approx([0.08, 0.015, 0.08])  # a plate on its rim
    fixtures = {f["id"]: f for f in view["fixtures"]}  # type: ignore[union-attr]
    assert set(fixtures) == {"rack_top", "rack_bottom"}
    assert fixtures["rack_top"]["kind"] == "rack" and fixtures["rack_top"]["open"] is False
    assert world_extent((1.0, 2.0, 3.0), world.scene().goals[0].orientation) == pytest.approx(
        [1.0, 3.0, 2.0]
    )


def test_the_page_gets_the_task_s_colours_words_and_accepted_sizes() -> None:
    scene = Scene(
        episode_id="colours",
        stamp=1.0,
        sequence=0,
        objects=[
            SceneObject(
                id="block_0",
                category="block",
                position=Vector3(x=0.5, y=0.0, z=0.02),
                size=Vector3(x=0.04, y=0.04, z=0.04),
                attributes={"colour": "red", "label": "bolt"},
            )
        ],
        goals=[
            SceneGoal(
                id="big_red",
                category="block",
                position=Vector3(x=0.4, y=0.1, z=0.035),
                accepts={"colour": "red", "size": [0.07, 0.07, 0.07]},
            ),
            SceneGoal(id="any", category="block", position=Vector3(x=0.4, y=-0.1, z=0.02)),
        ],
    )
    view = scene_view(scene)
    (block,) = view["objects"]  # type: ignore[misc]
    assert block["fill"] == "#d91f1a" and block["label"] == "colour red, label bolt"
    assert block["tag"] == "red, bolt"
    big, any_goal = view["goals"]  # type: ignore[misc]
    assert big["fill"] == "#d91f1a" and big["accepts"] == "colour red, size [0.07, 0.07, 0.07]"
    assert big["tag"] == "red"  # the size is drawn, not written
    assert big["extent"] == pytest.approx([0.07, 0.07, 0.07])  # drawn the size it accepts
    assert any_goal["fill"] is None and any_goal["accepts"] == ""
    assert any_goal["extent"] == pytest.approx([0.04, 0.04, 0.04])


def test_a_dish_turned_about_the_vertical_keeps_its_orientation_on_the_page() -> None:
    """A physical dish can rest turned about the vertical (a turned-over bowl at 13 deg was
    seen); the page shows the orientation its up axis says, as the planner reads it."""
    scene = dish_world().scene()
    dish = scene.objects[0]
    half = math.radians(135.0) / 2  # 135 deg about world z, then the dish's own pose
    cz, sz = math.cos(half), math.sin(half)
    q = dish.orientation
    turned = Quaternion(
        x=cz * q.x - sz * q.y,
        y=cz * q.y + sz * q.x,
        z=cz * q.z + sz * q.w,
        w=cz * q.w - sz * q.z,
    )
    moved = scene.replace(objects=[dish.replace(orientation=turned), *scene.objects[1:]])
    (shown, *_) = scene_view(moved)["objects"]  # type: ignore[misc]
    assert shown["orientation"] == nearest_orientation(q)
    assert nearest_orientation(turned) != nearest_orientation(q)  # what the page showed before


def test_clicks_from_the_page_are_checked_field_by_field() -> None:
    assert click_from_json({"object_id": "a", "goal_id": "b", "orientation_index": 2}) == Click(
        "a", "b", 2
    )
    assert click_from_json({"family_action": "toggle", "object_id": "rack_bottom"}) == Click(
        "rack_bottom", family_action="toggle"
    )
    for body, field in [
        ({"object_id": 3}, "object_id"),
        ({"goal_id": "x" * 65}, "goal_id"),
        ({"orientation_index": "up"}, "orientation_index"),
        ({"orientation_index": True}, "orientation_index"),
        ({"family_action": "Open Door"}, "family_action"),
        ({"family_action": 3}, "family_action"),
        ({"tray_action": "toggle_top"}, "tray_action"),
        ({"position": [0, 0, 0]}, "position"),
    ]:
        with pytest.raises(BadRequest, match=f"^{field}:"):
            click_from_json(body)


def test_a_demonstration_log_is_training_data(tmp_path: Path) -> None:
    from manigraph_training.dataset import load_demonstrations  # imports torch

    world = stack_world()
    session, _ = session_on(world)
    log = DemonstrationLog(tmp_path / "demos.mcap")
    steps = []
    for block, goal in (("block_2", "goal_0"), ("block_1", "goal_1")):
        session.on_scene(world.scene())
        scene = session.scene
        assert scene is not None
        action = session.act(Click(block, goal), wait=0)
        session.on_status(world.status(action, SkillState.SUCCEEDED))
        session.on_scene(world.scene())
        steps.append((scene, action))
    assert log.write(world.start, steps, world.end(success=True)) == 2
    log.close()
    demos = load_demonstrations([tmp_path / "demos.mcap"])
    assert (len(demos.samples), demos.episodes, demos.skipped) == (2, 1, 0)
    with pytest.raises(ValueError, match="scene_sequence"):
        DemonstrationLog(tmp_path / "bad.mcap").write(None, [(steps[1][0], steps[0][1])], None)


class App:
    """What the HTTP server needs of the service, over a real session (no bus)."""

    def __init__(self) -> None:
        self.session = DemoSession(Sink, "demos.mcap")
        self.stopping = threading.Event()
        self.episodes: list[dict[str, object]] = []

    def start_episode(self, fields: dict[str, object]) -> str:
        self.episodes.append(fields)
        return "ep-1"

    def act(self, click: Click) -> Action:
        return self.session.act(click)

    def page_defaults(self) -> dict[str, object]:
        return {"task": "stack"}


def request(
    port: int, method: str, path: str, body: bytes | None = None, **headers: str
) -> tuple[int, dict[str, object] | str]:
    connection = http.client.HTTPConnection("127.0.0.1", port, timeout=10)
    try:
        connection.request(method, path, body=body, headers=headers)
        response = connection.getresponse()
        data = response.read().decode()
        kind = response.getheader("Content-Type", "")
        return response.status, json.loads(data) if kind == "application/json" else data
    finally:
        connection.close()


@pytest.fixture
def served() -> Iterator[tuple[App, int]]:
    app = App()
    server = DemoHttpServer(("127.0.0.1", 0), app)
    thread = threading.Thread(target=server.serve_forever, daemon=True)
    thread.start()
    try:
        yield app, server.port
    finally:
        app.stopping.set()
        server.shutdown()
        server.server_close()


def test_the_server_serves_the_page_and_its_state(served: tuple[App, int]) -> None:
    _, port = served
    status, page = request(port, "GET", "/")
    assert status == 200 and "demo.js" in str(page)
    status, state = request(port, "GET", "/api/state")
    assert status == 200 and isinstance(state, dict)
    assert state["busy"] == "no episode yet: start one" and state["defaults"] == {"task": "stack"}
    assert request(port, "GET", "/nothing")[0] == 404


def test_the_server_refuses_other_sites_and_anything_but_small_json(
    served: tuple[App, int],
) -> None:
    app, port = served
    body = json.dumps({"task": "stack"}).encode()
    json_type = {"Content-Type": "application/json"}
    assert request(port, "GET", "/api/state", Host="evil.example:80")[0] == 421
    status, reply = request(port, "POST", "/api/episode", body, **json_type)
    assert (status, reply) == (200, {"ok": True, "episode_id": "ep-1"})
    for headers, field in [
        ({"Content-Type": "text/plain"}, "Content-Type"),
        ({**json_type, "Origin": "http://evil.example"}, "Origin"),
    ]:
        status, reply = request(port, "POST", "/api/episode", body, **headers)
        assert status == 400 and str(reply["error"]).startswith(f"{field}:")  # type: ignore[index]
    big = json.dumps({"object_id": "x" * 5000}).encode()
    status, reply = request(port, "POST", "/api/action", big, **json_type)
    assert status == 400 and str(reply["error"]).startswith("Content-Length:")  # type: ignore[index]
    status, reply = request(port, "POST", "/api/action", b"[1]", **json_type)
    assert status == 400 and reply["error"] == "body: must be a JSON object"  # type: ignore[index]
    status, reply = request(port, "POST", "/api/action", b'{"goal_id": "g"}', **json_type)
    assert status == 400 and "click an object first" in str(reply["error"])  # type: ignore[index]
    assert app.episodes == [{"task": "stack"}]


# --- a policy proposes, the person accepts or corrects (demo-ui --propose) ----------------------
def proposing_session(world: World) -> tuple[DemoSession, Sink]:
    sink = Sink()
    session = DemoSession(lambda: sink, "demos.mcap", clock=world.tick, proposer="expert")
    session.expect(world.request)
    session.on_episode(world.start)
    session.on_scene(world.scene())
    return session, sink


def test_a_proposal_is_shown_and_held_and_never_sent_by_itself() -> None:
    world = stack_world()
    session, _ = proposing_session(world)
    scene = session.wants_proposal()
    assert scene is not None and session.snapshot()["proposer"] == {
        "policy": "expert",
        "thinking": True,
        "proposal": None,
    }
    session.propose(scene, Click("block_2", "goal_0"))
    assert session.wants_proposal() is None  # asked once per world
    proposer = session.snapshot()["proposer"]
    assert proposer["proposal"]["text"] == "block_2 -> goal_0"  # type: ignore[index]
    assert not proposer["thinking"]  # type: ignore[index]
    session.on_scene(world.scene())  # time passes, newer scenes of the same world come ...
    assert session.pending is None and session.step == 0  # ... and nothing moved
    assert session.snapshot()["proposer"]["proposal"] is not None  # type: ignore[index]


def test_accepting_and_correcting_are_the_person_s_steps_and_say_which_they_were() -> None:
    world = stack_world()
    session, sink = proposing_session(world)
    scene = session.wants_proposal()
    assert scene is not None
    session.propose(scene, Click("block_2", "goal_0"))
    corrected = session.act(Click("block_1", "goal_0"))  # another pair: a correction
    assert (corrected.object_id, corrected.policy) == ("block_1", "human:corrected")
    assert corrected.scene_sequence == scene.sequence
    assert session.snapshot()["proposer"]["proposal"] is None  # type: ignore[index]
    session.on_status(world.status(corrected, SkillState.SUCCEEDED))
    assert session.wants_proposal() is None  # the robot's result, not yet a fresh view
    session.on_scene(world.scene())
    scene = session.wants_proposal()
    assert scene is not None  # a new world: the policy is asked again
    session.propose(scene, Click("block_2", "goal_1"))
    accepted = session.act(Click("block_2", "goal_1"))  # Accept sends the proposed pair
    assert accepted.policy == "human:accepted"
    session.on_status(world.status(accepted, SkillState.SUCCEEDED))
    session.on_scene(world.scene())
    session.on_episode(world.end(success=True))
    ((_, steps, _),) = sink.written
    assert [(a.object_id, a.goal_id, a.policy) for _, a in steps] == [
        ("block_1", "goal_0", "human:corrected"),
        ("block_2", "goal_1", "human:accepted"),
    ]
    episode = session.snapshot()["episode"]
    assert (episode["accepted"], episode["corrected"]) == (1, 1)  # type: ignore[index]


def test_a_proposal_for_a_world_that_is_gone_or_one_the_page_would_refuse_is_not_shown() -> None:
    world = stack_world()
    session, _ = proposing_session(world)
    old = session.wants_proposal()
    assert old is not None
    moved = session.act(Click("block_2", "goal_0"))  # the person did not wait
    assert moved.policy == "human"  # nothing was proposed on that world
    session.on_status(world.status(moved, SkillState.SUCCEEDED))
    after = world.scene()  # the test's world does not move blocks: it is filled by hand
    goals = [g.replace(filled=g.id == "goal_0") for g in after.goals]
    session.on_scene(after.replace(goals=goals))
    session.propose(old, Click("block_2", "goal_0"))  # the late answer about the old world
    assert session.snapshot()["proposer"]["proposal"] is None  # type: ignore[index]
    scene = session.wants_proposal()
    assert scene is not None
    session.propose(scene, Click("ghost", "goal_1"))
    assert session.snapshot()["proposer"]["proposal"] is None  # type: ignore[index]
    assert "the page refuses" in session.snapshot()["messages"][-1]["text"]  # type: ignore[index]
    assert session.wants_proposal() is None  # asked about this world: the person clicks


def test_the_proposer_asks_the_policy_in_its_own_thread_and_a_bad_policy_is_refused() -> None:
    from manigraph_shared.errors import ConfigError
    from manigraph_tools.click_page.proposer import Proposer, load_proposer

    world = stack_world()
    session, _ = proposing_session(world)
    stopping = threading.Event()
    proposer = Proposer(session, load_proposer("expert"), stopping)
    proposer.start()
    try:
        deadline = time.monotonic() + 10
        while session.snapshot()["proposer"]["proposal"] is None:  # type: ignore[index]
            assert time.monotonic() < deadline, session.snapshot()["messages"]
            time.sleep(0.05)
    finally:
        stopping.set()
        proposer.thread.join(5)
    assert session.pending is None and session.step == 0
    with pytest.raises(ConfigError, match="propose: policy: 'nobody'"):
        load_proposer("nobody")


def test_a_shelf_episode_plays_on_the_page_its_cupboard_drawn_and_given_no_button() -> None:
    from manigraph_tools.click_page.service import _family_fields

    world = World(EpisodeRequest(episode_id="ep-shelf", task="shelf", objects=4, seed=53950))
    scene = world.scene()
    view = scene_view(scene)
    fixtures = {f["id"]: f for f in view["fixtures"]}  # type: ignore[union-attr]
    assert {f["kind"] for f in fixtures.values()} == {"board", "wall"}
    for fixture in scene.fixtures:  # upright boxes: their extents are their sizes
        assert fixture.size is not None
        assert fixtures[fixture.id]["extent"] == pytest.approx(fixture.size.as_tuple())
    actions = _family_fields()["fixture_actions"]
    assert not {"board", "wall"} & set(actions)  # the page draws no button for them
    session, _ = session_on(world)
    slot = next(g for g in scene.goals if g.attributes["shelf_row"] == "back")
    place = session.act(Click("block_0", slot.id))
    # a plain pick and place: no orientation for a slot that stands in no fixture
    assert (place.goal_id, place.orientation_index, place.family_action) == (slot.id, None, None)
