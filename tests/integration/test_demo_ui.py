"""The demonstration page in a real headless Chromium: a person's clicks become a demonstration
that ``manigraph train`` learns from.

A real stack (router, geometric sim, skills and ``manigraph demo-ui``, no planner) on loopback;
Debian's ``chromium`` driven by Playwright clicks through whole demonstrations, bad clicks
included, then the MCAP file is checked and trained on. Skipped, saying why, where Chromium or
Playwright is missing (``scripts/install-chromium.sh`` installs it; CI does).

``MANIGRAPH_DEMO_UI_SCREENSHOT=docs/demo-ui.png`` also saves the page mid-demonstration.
"""

from __future__ import annotations

import json
import os
import queue
import random
import shutil
import signal
import subprocess
import sys
import threading
import time
import urllib.request
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import pytest

from manigraph_dishwasher.fixtures import TrayAction
from manigraph_shared.errors import CONFIG_EXIT_CODE
from manigraph_shared.mcap_log import decode_log
from manigraph_shared.messages import Action, EpisodeEvent, EpisodePhase, Scene
from manigraph_testkit.testing import Stack, free_port, stack

pytestmark = pytest.mark.integration

CHROMIUM = os.environ.get("MANIGRAPH_CHROMIUM") or shutil.which("chromium")
if CHROMIUM is not None and not Path(CHROMIUM).is_file():
    CHROMIUM = None
try:
    from playwright.sync_api import Page, sync_playwright
    from playwright.sync_api import TimeoutError as PlaywrightTimeout
except ImportError:  # pragma: no cover - the dev group installs it
    sync_playwright = None  # type: ignore[assignment]

needs_chromium = pytest.mark.skipif(
    CHROMIUM is None or sync_playwright is None,
    reason="needs Debian's chromium (scripts/install-chromium.sh, as root) and playwright "
    "(the dev dependency group)",
)
#: Longest wait for the page to show something (ms): a loaded 2-core machine is slow.
WAIT_MS = 60_000


@pytest.fixture(scope="module")
def world(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Stack]:
    """Router, geometric sim and skills: the stack a person demonstrates on (no planner)."""
    with stack(tmp_path_factory.mktemp("demo-ui-stack")) as running:
        running.start("router")
        running.start("sim", "sim")
        running.start("skills", "skills")
        with running.client() as bus:
            running.wait_alive(bus, "sim", "skills")
        yield running


@dataclass
class Person:
    """Someone at the page; every click on it is counted."""

    page: Page
    url: str
    clicks: int = 0
    log: list[str] = field(default_factory=list)

    def click(self, selector: str) -> None:
        self.page.locator(selector).click(timeout=WAIT_MS)
        self.clicks += 1
        self.log.append(selector)

    def state(self) -> dict[str, Any]:
        return self.page.request.get(self.url + "api/state").json()  # type: ignore[no-any-return]

    def wait_ready(self) -> None:
        self.page.wait_for_selector('#robot-state[data-ready="true"]', timeout=WAIT_MS)

    def wait_notice(self, text: str) -> str:
        self.page.wait_for_function(
            "text => document.getElementById('notice').textContent.includes(text)",
            arg=text,
            timeout=WAIT_MS,
        )
        return self.page.locator("#notice").inner_text()

    def wait_message(self, text: str) -> None:
        """Wait for a message saying ``text`` among the page's latest."""
        try:
            self.page.wait_for_function(
                "text => [...document.querySelectorAll('#messages li')]"
                ".some(li => li.textContent.includes(text))",
                arg=text,
                timeout=WAIT_MS,
            )
        except PlaywrightTimeout:
            said = [m["text"] for m in self.state()["messages"]]
            raise AssertionError(f"no message with {text!r}; the page said {said}") from None

    def start_episode(self) -> str:
        before = (self.state().get("episode") or {}).get("id")
        self.click("#start")
        self.page.wait_for_function(
            "before => { const e = document.getElementById('episode').textContent;"
            " return e.startsWith('demo-') && !e.startsWith(before + ' '); }",
            arg=str(before),
            timeout=WAIT_MS,
        )
        self.wait_ready()
        return str(self.state()["episode"]["id"])

    def click_thing(self, thing_id: str) -> None:
        """Click ``thing_id`` where it is not covered: in the top view, else in the side view
        (a person clicks where they see it). The views are redrawn on every Scene, so it is
        looked for again until the page settles."""
        deadline = time.monotonic() + WAIT_MS / 1000
        while not self._click_where_visible(thing_id):
            if time.monotonic() > deadline:
                raise AssertionError(f"{thing_id} is covered in both views")
            time.sleep(0.2)

    def _click_where_visible(self, thing_id: str) -> bool:
        for view in ("#top-view", "#side-view"):
            selector = f'{view} [data-id="{thing_id}"]'
            if self.page.locator(selector).count() and self.page.evaluate(
                """selector => {
                    const node = document.querySelector(selector);
                    const box = node.getBoundingClientRect();
                    const hit = document.elementFromPoint(box.x + box.width / 2,
                                                          box.y + box.height / 2);
                    return hit !== null && node.contains(hit);
                }""",
                selector,
            ):
                self.click(selector)
                return True
        return False

    def move(self, object_id: str, goal_id: str) -> None:
        """Select ``object_id`` (unless the page shows it selected still), then ``goal_id``."""
        self.wait_ready()
        if self.page.locator("#selection").get_attribute("data-object") != object_id:
            self.click_thing(object_id)
        self.click_thing(goal_id)

    def toggle(self, rack: str) -> None:
        self.wait_ready()
        self.click(f"#fixture-{rack}")


@pytest.fixture
def open_page(world: Stack, tmp_path: Path) -> Iterator[Any]:
    """``open_page(*demo_ui_flags) -> (Person, output file)``: a demo-ui process on the world
    and Chromium on its page."""
    assert sync_playwright is not None and CHROMIUM is not None
    names: list[str] = []
    with sync_playwright() as playwright:
        browser = playwright.chromium.launch(
            executable_path=CHROMIUM,
            args=["--no-sandbox"] if os.geteuid() == 0 else [],  # root (CI) needs no sandbox
        )

        def start(*flags: str) -> tuple[Person, Path]:
            name = f"demo-ui-{len(names)}"
            port = free_port()
            output = tmp_path / f"{name}.mcap"
            world.start(name, "demo-ui", "--http-port", str(port), "--output", str(output), *flags)
            names.append(name)
            with world.client() as bus:
                world.wait_alive(bus, "demo-ui")
            page = browser.new_page(viewport={"width": 1400, "height": 1000})
            url = f"http://127.0.0.1:{port}/"
            page.goto(url)
            page.wait_for_selector('#connection[data-state="live"]', timeout=WAIT_MS)
            return Person(page, url), output

        try:
            yield start
        finally:
            browser.close()
            for name in names:
                world.stop(name)


def recorded(output: Path) -> tuple[list[EpisodeEvent], list[tuple[Scene, Action]]]:
    """The episode events and each action with the scene it names, from a demonstration log."""
    messages = decode_log(output)
    scenes = {(m.episode_id, m.sequence): m for m in messages if isinstance(m, Scene)}
    events = [m for m in messages if isinstance(m, EpisodeEvent)]
    pairs = [
        (scenes[(m.episode_id, m.scene_sequence)], m) for m in messages if isinstance(m, Action)
    ]
    return events, pairs


def train(world: Stack, demos: Path, checkpoint: Path, epochs: int) -> dict[str, Any]:
    result = world.run(
        "train", str(demos), "--epochs", str(epochs), "-o", str(checkpoint), timeout=600
    )
    assert result.returncode == 0, result.stderr[-3000:]
    return json.loads(result.stdout.strip().splitlines()[-1])  # type: ignore[no-any-return]


@needs_chromium
@pytest.mark.timeout(1200)  # a loaded 2-core machine: torch's import alone took minutes
def test_a_block_stacking_demonstration_clicked_in_chromium_trains_a_policy(
    world: Stack, open_page: Any, tmp_path: Path
) -> None:
    person, output = open_page("--task", "stack", "--blocks", "3", "--seed", "3")
    episode = person.start_episode()

    # Bad clicks: a goal without an object never reaches the robot ...
    state = person.state()
    goals = sorted(state["scene"]["goals"], key=lambda g: g["z"])
    person.click_thing(goals[0]["id"])
    assert "click an object first" in person.wait_notice("click an object first")
    # ... and what the world refuses (the bottom block of a stack) is said and not recorded.
    blocks = sorted(state["scene"]["objects"], key=lambda o: o["z"])
    person.move(blocks[0]["id"], goals[0]["id"])
    person.wait_message("object_covered")

    # The demonstration: the top block onto the lowest free goal, three times.
    for _ in range(3):
        person.wait_ready()
        scene = person.state()["scene"]
        free = [g for g in scene["goals"] if not g["filled"]]
        loose = [o for o in scene["objects"] if not o["filled"]]
        person.move(max(loose, key=lambda o: o["z"])["id"], min(free, key=lambda g: g["z"])["id"])
    person.wait_message("demonstration 1 recorded")
    assert person.clicks == 1 + 1 + 2 + 6

    events, pairs = recorded(output)
    assert [e.phase for e in events] == [EpisodePhase.START, EpisodePhase.END]
    assert events[-1].success and events[-1].episode_id == episode
    assert len(pairs) == 3  # the refused step is not part of it
    assert all(a.policy == "human" and a.scene_sequence == s.sequence for s, a in pairs)
    assert [a.decision_id for _, a in pairs] == [f"{episode}:{step}" for step in (1, 2, 3)]

    checkpoint = tmp_path / "blocks.pt"
    metrics = train(world, output, checkpoint, epochs=3)
    assert metrics["checkpoint"]["path"] == str(checkpoint)
    from manigraph_planner.policies import load_policy

    policy = load_policy(str(checkpoint))
    scene = pairs[0][0]
    decision = policy.decide(scene)
    assert decision is not None and decision.object_id in {o.id for o in scene.objects}


@needs_chromium
@pytest.mark.timeout(1200)
def test_a_late_answer_to_a_goal_click_keeps_the_object_selected_since(
    world: Stack, open_page: Any
) -> None:
    """On a busy machine the answer to a goal click can come after the person has selected
    the next object. That selection, and the goal click after it, must go through: the late
    answer used to clear it, so the next goal went out without an object (issue 45)."""
    person, _ = open_page("--task", "stack", "--blocks", "3", "--seed", "3")
    person.start_episode()
    scene = person.state()["scene"]
    blocks = sorted(scene["objects"], key=lambda o: -o["z"])  # the top block first
    goals = sorted(scene["goals"], key=lambda g: g["z"])  # the lowest goal first
    bodies: list[dict[str, Any]] = []
    held: list[Any] = []

    def hold_the_first(route: Any) -> None:
        bodies.append(route.request.post_data_json)
        if len(bodies) == 1:
            held.append(route)  # answered when the test says so
        else:
            route.continue_()

    person.page.route("**/api/action", hold_the_first)
    person.move(blocks[0]["id"], goals[0]["id"])
    # From the click on, the page does not say "ready": its click is on its way.
    assert person.page.locator("#robot-state").get_attribute("data-ready") == "false"
    person.click_thing(blocks[1]["id"])  # the next object, before the first click's answer
    deadline = time.monotonic() + WAIT_MS / 1000
    while not held:
        assert time.monotonic() < deadline, "the goal click never left the page"
        person.page.wait_for_timeout(50)
    with person.page.expect_response("**/api/action", timeout=WAIT_MS):
        held[0].continue_()
    person.wait_message(f"{blocks[0]['id']} -> {goals[0]['id']}: done")
    person.wait_ready()  # the state after the first click: the answer has been read
    assert person.page.locator("#selection").get_attribute("data-object") == blocks[1]["id"]
    person.click_thing(goals[1]["id"])
    person.wait_message(f"{blocks[1]['id']} -> {goals[1]['id']}: done")
    assert [(b.get("object_id"), b.get("goal_id")) for b in bodies] == [
        (blocks[0]["id"], goals[0]["id"]),
        (blocks[1]["id"], goals[1]["id"]),
    ]


@needs_chromium
@pytest.mark.timeout(600)
def test_a_policy_proposes_a_click_corrects_it_and_the_correction_is_recorded(
    world: Stack, open_page: Any
) -> None:
    """``--propose expert`` on a task file whose rule (red to the left bins) only the person
    knows: the expert proposes any block for any bin and the robot waits; a click corrects
    the first proposal to the rule, Accept takes the others; the MCAP holds the correction
    as the label of the scene it was shown on."""
    task_file = Path(__file__).parents[2] / "examples/tasks/unwritten/colour-place.toml"
    person, output = open_page("--task-file", str(task_file), "--seed", "5", "--propose", "expert")
    person.start_episode()
    person.page.wait_for_selector('#proposal:not([data-object=""])', timeout=WAIT_MS)
    state = person.state()
    proposal = state["proposer"]["proposal"]
    scene = state["scene"]
    assert all(goal["accepts"] == "" for goal in scene["goals"])  # no rule reaches the page
    person.page.wait_for_timeout(1000)  # held: nothing moves until the person clicks
    held = person.state()
    assert held["episode"]["goals_filled"] == 0 and held["busy"] is None
    assert held["proposer"]["proposal"] == proposal

    # The correction: a red block to a left bin, not the pair proposed.
    red = [o["id"] for o in scene["objects"] if o["tag"] == "red"]
    pair = next(
        (block, goal)
        for block in red
        for goal in ("left_0", "left_1")
        if (block, goal) != (proposal["object_id"], proposal["goal_id"])
    )
    person.click_thing(pair[0])
    if os.environ.get("MANIGRAPH_DEMO_UI_CORRECT_SCREENSHOT"):
        person.page.screenshot(path=os.environ["MANIGRAPH_DEMO_UI_CORRECT_SCREENSHOT"])
    person.click_thing(pair[1])
    person.wait_message(f"{pair[0]} -> {pair[1]}: corrected, sent")
    for step in range(3):  # the rest as proposed: Accept
        person.wait_ready()
        person.page.wait_for_function(
            "n => document.getElementById('progress').textContent.includes(`${n} accepted`)"
            " && !document.getElementById('accept').disabled",
            arg=step,
            timeout=WAIT_MS,
        )
        person.click("#accept")
    person.wait_message("demonstration 1 recorded")
    assert person.clicks == 1 + 2 + 3

    _, pairs = recorded(output)
    assert len(pairs) == 4
    corrected, *accepted = pairs
    shown, action = corrected
    assert (action.object_id, action.goal_id, action.policy) == (*pair, "human:corrected")
    assert shown.sequence == action.scene_sequence and not any(g.filled for g in shown.goals)
    assert (proposal["object_id"], proposal["goal_id"]) != pair  # the label is the person's
    assert [a.policy for _, a in accepted] == ["human:accepted"] * 3


def _dish_plan(scene: dict[str, Any], rng: random.Random) -> tuple[list, list]:
    """Bowls into free top bowl slots, plates into free bottom plate slots (top-bottom)."""
    dishes = {
        c: [o["id"] for o in scene["objects"] if o["category"] == c] for c in ("bowl", "plate")
    }
    slots = {
        c: [g["id"] for g in scene["goals"] if g["fixture"] == rack and g["category"] == c]
        for c, rack in (("bowl", "rack_top"), ("plate", "rack_bottom"))
    }
    return (
        list(zip(dishes["bowl"], rng.sample(slots["bowl"], len(dishes["bowl"])), strict=True)),
        list(zip(dishes["plate"], rng.sample(slots["plate"], len(dishes["plate"])), strict=True)),
    )


@needs_chromium
@pytest.mark.timeout(1200)
def test_a_ten_dish_demonstration_takes_at_most_30_clicks_and_trains_the_dishwasher_policy(
    world: Stack, open_page: Any, tmp_path: Path
) -> None:
    person, output = open_page(
        "--task", "dishwasher", "--objects", "10", "--preference", "top-bottom", "--seed", "7"
    )

    # A first episode of bad clicks, then left for a new one: none of it is recorded.
    person.start_episode()
    scene = person.state()["scene"]
    bowl = next(o["id"] for o in scene["objects"] if o["category"] == "bowl")
    plate = next(o["id"] for o in scene["objects"] if o["category"] == "plate")
    person.click_thing("top_bowl_00")
    person.wait_notice("click an object first")
    person.move(bowl, "top_bowl_00")  # the top rack is pushed in
    person.wait_message("rack_closed")
    person.move(plate, "top_bowl_01")  # a plate into a bowl slot: refused by the page
    person.wait_notice("it goes to a plate goal")
    person.toggle("rack_top")
    person.toggle("rack_bottom")
    person.move(plate, "bottom_plate_00")  # the top rack is out
    person.wait_message("top_rack_open")

    # The measured demonstration: 10 dishes, from "Start episode" to the last rack pushed in.
    person.clicks = 0
    episode = person.start_episode()
    person.wait_message("is discarded")
    bowls, plates = _dish_plan(person.state()["scene"], random.Random(7))
    person.toggle("rack_top")
    for number, (dish, slot) in enumerate(bowls):
        person.move(dish, slot)
        if number == 2 and os.environ.get("MANIGRAPH_DEMO_UI_SCREENSHOT"):
            person.wait_ready()
            person.click_thing(bowls[number + 1][0])  # a dish selected, as mid-demonstration
            person.page.screenshot(path=os.environ["MANIGRAPH_DEMO_UI_SCREENSHOT"])
            person.click_thing(bowls[number + 1][0])  # and deselected again
            person.clicks -= 2
    person.toggle("rack_top")
    person.toggle("rack_bottom")
    for dish, slot in plates:
        person.move(dish, slot)
    person.toggle("rack_bottom")
    person.wait_message("demonstration 1 recorded")
    print(f"\n10-dish demonstration: {person.clicks} clicks")
    assert person.clicks <= 30
    assert person.clicks == 1 + 4 + 2 * 10

    events, pairs = recorded(output)
    assert [(e.episode_id, e.phase) for e in events] == [
        (episode, EpisodePhase.START),
        (episode, EpisodePhase.END),
    ]
    assert events[-1].success
    assert len(pairs) == 14
    toggles = [TrayAction.of(a) for _, a in pairs if a.family_action is not None]
    assert toggles == [TrayAction.TOGGLE_TOP] * 2 + [TrayAction.TOGGLE_BOTTOM] * 2
    placements = [a for _, a in pairs if a.family_action is None]
    assert all(
        a.orientation_index == (1 if a.object_id.startswith("bowl") else 2) for a in placements
    )

    checkpoint = tmp_path / "dishwasher.pt"
    metrics = train(world, output, checkpoint, epochs=20)
    assert metrics["heads"] == "dishwasher"
    from manigraph_planner.policies import load_policy

    policy = load_policy(str(checkpoint))
    assert type(policy).__name__ == "DishwasherGNNPolicy"
    scene = pairs[1][0]  # the top rack pulled out: a bowl can go in, so there is a decision
    decision = policy.decide(scene)
    assert decision is not None
    assert decision.object_id in {o.id for o in scene.objects} | {f.id for f in scene.fixtures}


@pytest.mark.timeout(600)
def test_up_with_policy_human_serves_the_page_and_starts_no_planner(tmp_path: Path) -> None:
    page_port = free_port()
    process = subprocess.Popen(
        [
            sys.executable,
            "-m",
            "manigraph_shared.cli",
            "up",
            "--policy",
            "human",
            "--task",
            "dishwasher",
            "--objects",
            "4",
            "--port",
            str(free_port()),
            "--demo-port",
            str(page_port),
            "--demo-output",
            str(tmp_path / "demos.mcap"),
        ],
        stdout=subprocess.DEVNULL,
        stderr=subprocess.PIPE,
        text=True,
    )
    lines: queue.SimpleQueue[str] = queue.SimpleQueue()
    threading.Thread(target=lambda: [lines.put(line) for line in process.stderr or []]).start()
    try:
        deadline = time.monotonic() + 400
        up = ""
        while not up.startswith("stack is up"):
            assert process.poll() is None, "manigraph up exited"
            try:
                up = lines.get(timeout=max(0.0, deadline - time.monotonic()))
            except queue.Empty:
                raise AssertionError("the stack did not come up") from None
        assert up.startswith("stack is up: router, sim, demo-ui, skills")
        assert "planner" not in up
        with urllib.request.urlopen(f"http://127.0.0.1:{page_port}/api/state", timeout=30) as reply:
            state = json.load(reply)
        assert state["defaults"]["task"] == "dishwasher" and state["defaults"]["objects"] == 4
        assert state["busy"] == "no episode yet: start one" and not state["planner_running"]
    finally:
        process.send_signal(signal.SIGINT)
        process.wait(timeout=60)


def test_up_with_policy_human_refuses_episodes_a_person_must_start() -> None:
    result = subprocess.run(
        [
            sys.executable,
            "-m",
            "manigraph_shared.cli",
            "up",
            "--policy",
            "human",
            "--episodes",
            "1",
        ],
        capture_output=True,
        text=True,
        timeout=300,
        check=False,
    )
    assert result.returncode == CONFIG_EXIT_CODE
    assert "episodes: --policy human: a person starts each episode on the page" in result.stderr


def test_up_refuses_a_proposing_policy_without_the_page_to_show_it() -> None:
    result = subprocess.run(
        [sys.executable, "-m", "manigraph_shared.cli", "up", "--propose", "expert"],
        capture_output=True,
        text=True,
        timeout=300,
        check=False,
    )
    assert result.returncode == CONFIG_EXIT_CODE
    assert "propose: only with --policy human" in result.stderr


@needs_chromium
@pytest.mark.timeout(600)
def test_a_shelf_demonstration_is_clicked_with_its_cupboard_drawn_and_no_fixture_button(
    world: Stack, open_page: Any
) -> None:
    person, output = open_page("--task", "shelf", "--objects", "2", "--seed", "53951")
    episode = person.start_episode()
    scene = person.state()["scene"]
    panels = {f["id"] for f in scene["fixtures"]}
    assert len(panels) == 5  # two boards, two sides and the back wall
    for view in ("#top-view", "#side-view"):  # every panel drawn as its box, in both views
        drawn = person.page.locator(f"{view} .fixture-box").evaluate_all(
            "nodes => nodes.map(n => n.dataset.fixture)"
        )
        assert set(drawn) == panels
    assert person.page.locator("#fixture-buttons button").count() == 0
    assert person.page.locator("#fixtures").is_hidden()
    assert person.page.locator("#orientations").is_hidden()  # no slot stands in a fixture

    for row in ("back", "front"):  # a column is filled back first
        person.wait_ready()
        scene = person.state()["scene"]
        slot = next(g["id"] for g in scene["goals"] if g["id"].endswith(row))
        block = next(o["id"] for o in scene["objects"] if not o["filled"])
        person.move(block, slot)
    person.wait_message("demonstration 1 recorded")

    events, pairs = recorded(output)
    assert events[-1].success and events[-1].episode_id == episode
    assert len(pairs) == 2 and all(s.fixtures for s, _ in pairs)
    assert all(a.orientation_index is None and a.family_action is None for _, a in pairs)
