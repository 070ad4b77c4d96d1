"""A person in the planner's place: clicks become ``Action``s, and good steps a demonstration.

:class:`DemoSession` is the demonstration page's logic, with no bus and no HTTP (the service
wires it to both). It follows the world as the planner does (:mod:`manigraph_planner.decisions`):

* one decision at a time: a click while the robot is still busy is refused, and so is a click
  before a scene observed *after* the last skill ended has arrived, so a person, like the
  planner, never acts on a stale world;
* a click is checked before it is sent: a goal without an object, an id the scene does not
  have (or hides), an object sent to a goal of another category, a family action on a
  fixture the world has not, and any click while a planner runs, are refused with a message
  for the page and never reach the robot;
* what the skills (or the world behind them) refuse, e.g. ``rack_closed``, ``top_rack_open``,
  ``slot_taken``, ``object_covered``, comes back as a failed ``SkillStatus``: the page shows its
  reason and the step is **not** part of the demonstration;
* with a proposing policy (``demo-ui --propose``, :mod:`.proposals`) its decision for the
  world is shown and held, never sent: the person's click sends it (accepted) or another pair
  (corrected), and the step records which;
* a demonstration is the episode's succeeded steps, each with the scene it was decided on; it is
  written only when the world ends the episode with success. An episode that fails, or that is
  left for a new one, is discarded with a message: a demonstration is never broken.

Thread-safe: scenes, statuses and events come from the bus, clicks from HTTP threads. Every
change bumps :attr:`version`, which the page's event stream waits on.
"""

from __future__ import annotations

import threading
import time
from collections import deque
from collections.abc import Callable
from dataclasses import dataclass
from typing import Protocol

from manigraph_shared.errors import ManigraphError
from manigraph_shared.messages import (
    Action,
    EpisodeEvent,
    EpisodePhase,
    EpisodeRequest,
    Scene,
    SkillState,
    SkillStatus,
)
from manigraph_shared.orientations import ORIENTATION_NAMES
from manigraph_tools.click_page.clicks import (
    ACCEPTED,
    CORRECTED,
    Click,
    ClickRefused,
    action_for,
    describe,
)
from manigraph_tools.click_page.proposals import Proposals
from manigraph_tools.click_page.scene_view import same_world, scene_view

#: A decision whose skill never reports is given up after this long (seconds).
DECISION_TIMEOUT = 60.0
#: Messages kept for the page.
MESSAGES_KEPT = 30

#: What a refusal reason means, for people (the reason itself is shown too).
HINTS = {
    "rack_closed": "pull the rack out first",
    "top_rack_open": "push the top rack in before loading the bottom one",
    "slot_taken": "that slot already holds a dish",
    "wrong_slot": "a slot takes only its own kind of dish",
    "gripper_full": "the gripper is holding something",
    "object_covered": "take what lies on top of it first",
    "outside_workspace": "the robot cannot reach there",
}


class DemonstrationSink(Protocol):
    """Where finished demonstrations go (``manigraph_shared.demonstrations.DemonstrationLog``)."""

    def write(
        self,
        start: EpisodeEvent | None,
        steps: list[tuple[Scene, Action]],
        end: EpisodeEvent | None,
    ) -> int: ...


@dataclass
class _Pending:
    action: Action
    scene: Scene
    since: float  # time.monotonic()


class DemoSession:
    """The page's state and rules (module docstring). ``sink()`` opens the demonstration log
    on the first demonstration, so a session that records nothing leaves no file."""

    def __init__(
        self,
        sink: Callable[[], DemonstrationSink],
        output: str,
        clock: Callable[[], float] = time.time,
        decision_timeout: float = DECISION_TIMEOUT,
        proposer: str | None = None,
    ) -> None:
        self._open_sink = sink
        self._sink: DemonstrationSink | None = None
        self.output = output
        self.clock = clock
        self.decision_timeout = decision_timeout
        self._lock = threading.Condition()
        self.version = 0
        self.episode_id: str | None = None
        self.request: EpisodeRequest | None = None
        self.start: EpisodeEvent | None = None
        self.end: EpisodeEvent | None = None
        self.scene: Scene | None = None
        self.pending: _Pending | None = None
        self.ready_after = 0.0
        self.step = 0
        self.steps: list[tuple[Scene, Action]] = []
        self.refused = 0
        self.finished = False
        self.demonstrations = 0
        self.decisions_recorded = 0
        self.planner_alive = False
        self.skills_alive = True
        self.messages: deque[dict[str, object]] = deque(maxlen=MESSAGES_KEPT)
        self.proposals = Proposals(proposer)

    # --- what the page sees ------------------------------------------------------------------
    def say(self, level: str, text: str) -> None:
        with self._lock:
            self.messages.append({"level": level, "text": text, "time": round(self.clock(), 3)})
            self._changed()

    def _changed(self) -> None:
        self.version += 1
        self._lock.notify_all()

    def wait_changed(self, version: int, timeout: float) -> int:
        """Wait until :attr:`version` differs from ``version`` (or ``timeout``); the new one."""
        with self._lock:
            self._lock.wait_for(lambda: self.version != version, timeout)
            return self.version

    def busy_reason(self) -> str | None:
        """Why a click cannot be sent now (None: it can)."""
        with self._lock:
            return self._busy_reason()

    def _busy_reason(self) -> str | None:
        if self.planner_alive:
            return (
                "a planner is running and decides for the robot: start the stack with "
                "`manigraph up --policy human` (no planner) to demonstrate"
            )
        if not self.skills_alive:
            return "the skills service is not running: nothing would execute a click"
        if self.episode_id is None or self.scene is None:
            return "no episode yet: start one"
        if self.end is not None or self.scene.episode_ended:
            return "the episode has ended: start a new one"
        if self.pending is not None:
            return f"the robot is busy with {self.pending.action.decision_id}"
        if self.scene.stamp <= self.ready_after:
            return "waiting for a fresh view of the world"
        return None

    def _settling(self) -> bool:
        """A skill is running, or its result is in but no scene observed after it yet: what
        keeps a person waiting a moment, as it keeps the planner."""
        scene = self.scene
        return self.pending is not None or (scene is not None and scene.stamp <= self.ready_after)

    def snapshot(self) -> dict[str, object]:
        """Everything the page draws, as JSON."""
        with self._lock:
            scene = self.scene
            goals = scene.goals if scene is not None else []
            objects = scene.objects if scene is not None else []
            pending = self.pending.action if self.pending is not None else None
            return {
                "version": self.version,
                "busy": self._busy_reason(),
                "planner_running": self.planner_alive,
                "episode": None
                if self.episode_id is None
                else {
                    "id": self.episode_id,
                    "task": self.start.task if self.start else None,
                    "seed": self.start.seed if self.start else None,
                    "ended": self.end is not None,
                    "success": self.end.success if self.end is not None else None,
                    "goals_filled": sum(g.filled for g in goals),
                    "goals_total": len(goals),
                    "objects_placed": sum(o.filled for o in objects),
                    "objects_total": len(objects),
                    "steps_recorded": len(self.steps),
                    "accepted": sum(a.policy == ACCEPTED for _, a in self.steps),
                    "corrected": sum(a.policy == CORRECTED for _, a in self.steps),
                    "refused": self.refused,
                },
                "proposer": self.proposals.view(scene, self._wants_proposal() is not None),
                "pending": None if pending is None else describe(pending),
                "scene": scene_view(scene) if scene is not None else None,
                "orientations": list(ORIENTATION_NAMES),
                "recorded": {
                    "demonstrations": self.demonstrations,
                    "decisions": self.decisions_recorded,
                    "file": self.output,
                },
                "messages": list(self.messages),
            }

    # --- the world ---------------------------------------------------------------------------
    def expect(self, request: EpisodeRequest) -> None:
        """A new episode is about to be asked for: leave the current one."""
        with self._lock:
            self._leave_episode("a new episode was started")
            self.request = request

    def on_episode(self, event: EpisodeEvent) -> None:
        with self._lock:
            if event.phase is EpisodePhase.START:
                if event.episode_id == self.episode_id and self.start is not None:
                    return  # the reset's answer and the broadcast: the same event twice
                if event.episode_id != self.episode_id:
                    self._leave_episode("the world started another episode")
                    self._begin(event.episode_id)
                self.start = event
                self.say("info", f"episode {event.episode_id} started ({event.task})")
            elif event.episode_id == self.episode_id and self.end is None:
                self.end = event
                self._finish()
            self._changed()

    def on_scene(self, scene: Scene) -> None:
        with self._lock:
            if scene.episode_id != self.episode_id:
                if self.episode_id is not None and not self.finished and self.end is None:
                    return  # another episode's scene overtook its start event: wait for it
                self._leave_episode("the world started another episode")
                self._begin(scene.episode_id)
            current = self.scene
            if current is not None and current.sequence > scene.sequence:
                return  # overtaken on the way
            self.scene = scene
            if not same_world(current, scene) or current is None:
                self._changed()
            elif current.stamp <= self.ready_after < scene.stamp:
                self._changed()  # the first fresh view since the last skill: ready again
            else:  # the same world, only a newer stamp: wake waiters, the page keeps its drawing
                self._lock.notify_all()

    def on_status(self, status: SkillStatus) -> None:
        with self._lock:
            pending = self.pending
            if pending is None or status.decision_id != pending.action.decision_id:
                return
            if not status.state.terminal:
                return
            self.pending = None
            self.ready_after = max(self.ready_after, status.stamp)
            what = describe(pending.action)
            if status.state is SkillState.SUCCEEDED:
                self.steps.append((pending.scene, pending.action))
                self.say("ok", f"{what}: done")
            else:
                self.refused += 1
                hint = HINTS.get(status.reason or "", "")
                self.say(
                    "error",
                    f"{what}: refused, {status.reason}"
                    + (f" ({status.detail})" if status.detail else "")
                    + (f": {hint}" if hint else "")
                    + "; not part of the demonstration",
                )
            self._finish()
            self._changed()

    def on_alive(self, service: str, alive: bool) -> None:
        with self._lock:
            if service == "planner" and alive != self.planner_alive:
                self.planner_alive = alive
                if alive:
                    self.say("error", "a planner is running: it decides, clicks are refused")
                self._changed()
            elif service == "skills" and alive != self.skills_alive:
                self.skills_alive = alive
                if not alive and self.pending is not None:
                    self._give_up("the skills service went away")
                self._changed()

    def tick(self, now: float) -> None:
        """Give up a decision whose skill never reports (``time.monotonic()`` ``now``)."""
        with self._lock:
            pending = self.pending
            if pending is not None and now - pending.since > self.decision_timeout:
                self._give_up(f"no result within {self.decision_timeout:g} s")
                self._changed()

    # --- proposals (demo-ui --propose) ------------------------------------------------------
    def wants_proposal(self) -> Scene | None:
        """The scene to ask the proposing policy about: the robot is free and the policy has
        not been asked about this world yet (None: nothing to ask)."""
        with self._lock:
            return self._wants_proposal()

    def _wants_proposal(self) -> Scene | None:
        scene = self.scene
        if scene is None or self._busy_reason() is not None:
            return None
        return scene if self.proposals.wanted(scene) else None

    def propose(self, scene: Scene, click: Click | None) -> None:
        """The policy's decision on ``scene`` (None: it has none), shown and held until the
        person clicks; dropped if the world has changed since it was asked."""
        with self._lock:
            if self._wants_proposal() is None or scene.episode_id != self.episode_id:
                return
            if not same_world(self.scene, scene):
                return  # decided on a world that is gone: it is asked again
            level, text = self.proposals.offer(scene, click, self.step, self.clock)
            self.say(level, text)

    # --- clicks ------------------------------------------------------------------------------
    def act(self, click: Click, wait: float = 0.0) -> Action:
        """The ``Action`` for ``click`` on the current scene (the caller publishes it), or
        :class:`ClickRefused` saying why not. A click that comes while the robot is still
        finishing waits up to ``wait`` seconds for the world to settle."""
        with self._lock:
            try:
                if click.family_action is None and click.object_id is None:
                    raise ClickRefused(
                        f"goal {click.goal_id} clicked without an object: click an object first"
                        if click.goal_id
                        else "click an object, then a goal"
                    )
                self._lock.wait_for(lambda: not self._settling(), wait)
                action = self._action_for(click)
            except ClickRefused as refusal:
                self.say("error", str(refusal))
                raise
            assert self.scene is not None
            label = self.proposals.label(action, self.scene)
            action = action.replace(policy=label)
            self.proposals.forget()
            self.pending = _Pending(action, self.scene, time.monotonic())
            self.step += 1
            said = {ACCEPTED: ": accepted, sent", CORRECTED: ": corrected, sent"}
            self.say("info", f"{describe(action)}{said.get(label, ': sent')}")
            return action

    def _action_for(self, click: Click) -> Action:
        busy = self._busy_reason()
        if busy is not None:
            raise ClickRefused(busy)
        assert self.scene is not None and self.episode_id is not None
        return action_for(click, self.scene, self.episode_id, self.step, self.clock)

    # --- the demonstration -------------------------------------------------------------------
    def _begin(self, episode_id: str) -> None:
        self.episode_id = episode_id
        self.start = self.end = None
        self.scene = None
        self.pending = None
        self.ready_after = 0.0
        self.step = 0
        self.steps = []
        self.refused = 0
        self.finished = False
        self.proposals.forget()

    def _leave_episode(self, why: str) -> None:
        if self.episode_id is not None and not self.finished and self.steps:
            self.say(
                "info",
                f"{why}: the unfinished demonstration of {self.episode_id} "
                f"({len(self.steps)} steps) is discarded",
            )
        self.finished = True

    def _give_up(self, why: str) -> None:
        assert self.pending is not None
        self.say("error", f"{describe(self.pending.action)}: given up, {why}")
        self.pending = None
        self.ready_after = self.clock()
        self.refused += 1
        self._finish()

    def _finish(self) -> None:
        """Write the demonstration once the episode ended and no step is in flight."""
        end = self.end
        if end is None or self.pending is not None or self.finished:
            return
        self.finished = True
        if not end.success:
            self.say(
                "error",
                f"episode {end.episode_id} ended without success ({end.reason or 'failed'}): "
                "not recorded",
            )
            return
        if not self.steps:
            self.say("info", f"episode {end.episode_id} ended with nothing demonstrated")
            return
        try:
            if self._sink is None:
                self._sink = self._open_sink()
            count = self._sink.write(self.start, list(self.steps), end)
        except (OSError, ManigraphError, ValueError) as exc:
            self.say("error", f"the demonstration of {end.episode_id} could not be written: {exc}")
            return
        self.demonstrations += 1
        self.decisions_recorded += count
        self.say(
            "ok",
            f"demonstration {self.demonstrations} recorded: {count} steps of "
            f"{end.episode_id} to {self.output}",
        )
