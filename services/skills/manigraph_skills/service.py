"""The skills service: executes planner decisions with the configured robot driver.

Nothing a sender does can block the threads that receive messages:

* scenes pass the :class:`~manigraph_shared.scene_gate.SceneGate` (running episode, sane
  sequence and stamp) on the Zenoh thread and go straight into the scene cache;
* an ``Action`` is checked on the Zenoh thread and put in a bounded queue (``queue_capacity``);
  a worker thread executes the queue in order. **Overflow policy: drop the newest.** An action
  arriving at a full queue, one for another episode than the one running, one whose scene is
  far ahead of any scene seen, and any action while the emergency stop is engaged are refused
  at once: counted (``ServiceStatus.rejections``) and answered with a failed ``SkillStatus``
  naming the reason, so a real planner decides again instead of waiting. Between episodes an
  action for a new episode may have overtaken that episode's start (the planner is one hop
  nearer): it is queued, and refused only if its episode has not started by the time its
  scene was waited for, or as soon as another episode starts: the start refuses every
  queued action of another episode at once, and ends the worker's wait for one, so actions
  forged for unknown episodes cost the next real episode milliseconds (each held the worker
  for ``scene_wait`` before, and 200 of them delayed the next episode by 3.5 s);
* the worker waits at most ``scene_wait`` seconds for the scene an action was decided on;
* the emergency stop (:meth:`on_estop`, from the stack's latch: unknown until it answers,
  and unknown is stopped) is acted on in the thread that learns it: the driver is stopped,
  the skill under way is reported failed with reason ``stopped`` from that thread at once
  (``ActionInFlight``: the worker may be planning or waiting for a scene; what it reports
  for that decision afterwards is dropped), queued actions are refused, and so is every
  action until the stop is released;
* when the robot's process (``robot_service``, the sim) goes away, the skill under way fails
  at once with reason ``robot_lost`` instead of waiting out the driver's timeout, so the
  next episode finds skills free.
"""

from __future__ import annotations

import queue
import sys
import threading
import time
from collections.abc import Callable

from manigraph_shared.bus import Bus
from manigraph_shared.messages import (
    Action,
    EpisodeEvent,
    EpisodePhase,
    EstopState,
    Scene,
    ServiceState,
    SkillState,
    SkillStatus,
)
from manigraph_shared.scene_gate import SceneGate
from manigraph_shared.service import Service
from manigraph_shared.workspace import Workspace
from manigraph_skills.drivers.base import RobotDriver
from manigraph_skills.in_flight import ActionInFlight
from manigraph_skills.pick_and_place import SKILL, PickAndPlace
from manigraph_skills.scene_cache import SceneCache

#: Actions waiting for the worker; a real planner has at most one decision in flight.
QUEUE_CAPACITY = 4
#: Longest the worker waits for the scene an action was decided on, seconds.
SCENE_WAIT = 1.0
#: An action decided on a scene this far ahead of the newest scene seen is refused unread.
MAX_SCENE_AHEAD = 50
#: Longest the worker (planning: Python-heavy IK) keeps the GIL while a Zenoh thread waits
#: for it, seconds (Python's default is 5 ms): the stop's callback needs the GIL to run.
GIL_SWITCH_INTERVAL = 0.001


class SkillsService(Service):
    name = "skills"

    def __init__(
        self,
        bus: Bus,
        driver_factory: Callable[[Bus], RobotDriver],
        workspace: Workspace,
        queue_capacity: int = QUEUE_CAPACITY,
        scene_wait: float = SCENE_WAIT,
        robot_service: str = "sim",
    ) -> None:
        super().__init__(bus)
        self.driver: RobotDriver = driver_factory(bus)
        self.skill = PickAndPlace(self.driver, workspace)
        self.gate = SceneGate()
        self.scenes = SceneCache()
        self.scene_wait = scene_wait
        self.robot_service = robot_service
        #: Set while the stop is engaged or not yet known (before the latch answers).
        self.stopped = threading.Event()
        self.stopped.set()
        self.stop_reason = self.estop.state.reason
        self._actions: queue.Queue[Action] = queue.Queue(queue_capacity)
        self.in_flight = ActionInFlight(bus.publish, SKILL)
        self._running: Action | None = None  # the action the worker executes
        self._worker = threading.Thread(target=self._work, name="skills-worker", daemon=True)

    def setup(self) -> None:
        sys.setswitchinterval(GIL_SWITCH_INTERVAL)
        self.bus.subscribe(EpisodeEvent, self._on_episode, on_error=self._rejected)
        self.bus.subscribe(Scene, self._on_scene, on_error=self._rejected)
        self.bus.subscribe(Action, self._on_action, on_error=self._rejected)
        self.bus.watch_alive(self._on_liveliness)
        self._worker.start()
        self.log.info("driver '%s'", self.driver.name)

    # --- Zenoh threads: check, cache, enqueue; never wait -----------------------------------
    def _on_episode(self, event: EpisodeEvent) -> None:
        running = self._running
        if running is not None:
            ours = running.episode_id == event.episode_id
            ended = event.phase is EpisodePhase.END
            if ours == ended:  # its episode ended, or another began: it may move nothing more
                self.driver.end_decision(running.decision_id, "episode_ended")
        for scene in self.gate.on_episode(event):  # overtook the event; acceptable now
            self._on_scene(scene)
        if event.phase is EpisodePhase.START:
            self._refuse_queued_of_others(event.episode_id)
            self.scenes.wake()  # a wait for another episode's scene is over

    def _refuse_queued_of_others(self, episode_id: str) -> None:
        """Refuse every queued action of another episode than ``episode_id``, which has just
        started (they could never run); keep that episode's own, in order."""
        kept: list[Action] = []
        others: list[Action] = []
        while True:
            try:
                queued = self._actions.get_nowait()
            except queue.Empty:
                break
            (kept if queued.episode_id == episode_id else others).append(queued)
        for queued in kept:
            try:
                self._actions.put_nowait(queued)
            except queue.Full:  # an action of the new episode took the place meanwhile
                self._refuse(queued, "skills_busy", f"{self._actions.maxsize} actions queued")
        for queued in others:
            self._refuse(queued, "not_running_episode", queued.episode_id)

    def _on_scene(self, scene: Scene) -> None:
        if self.admit(self.gate, scene):
            self.scenes.update(scene)

    def _on_action(self, action: Action) -> None:
        self.messages_in += 1
        newest = self.scenes.newest_sequence(action.episode_id)
        if self.stopped.is_set():
            self._refuse(action, "stopped", f"emergency stop engaged: {self.stop_reason}")
        elif not self.gate.may_be_next(action.episode_id):
            self._refuse(action, "not_running_episode", action.episode_id)
        elif newest is not None and action.scene_sequence > newest + MAX_SCENE_AHEAD:
            self._refuse(action, "unknown_scene", f"scene {action.scene_sequence} not seen")
        else:
            try:
                self._actions.put_nowait(action)
            except queue.Full:
                self._refuse(action, "skills_busy", f"{self._actions.maxsize} actions queued")

    def on_estop(self, state: EstopState) -> None:
        if state.engaged:  # (also at start, while the stop is unknown: the driver refuses)
            self.stopped.set()
            self.stop_reason = state.reason
            self.driver.stop()
            self.in_flight.stop(f"emergency stop engaged: {state.reason}")
            while True:  # what was queued is not done either
                try:
                    self._refuse(self._actions.get_nowait(), "stopped", "emergency stop engaged")
                except queue.Empty:
                    break
        else:
            self.driver.resume()
            self.stopped.clear()
            self.stop_reason = ""

    def _on_liveliness(self, service: str, alive: bool) -> None:
        if service == self.robot_service and not alive:
            if self.in_flight.under_way:
                self.log.warning("the robot (%s) went away: the skill under way fails", service)
            else:  # most often the stack shutting down: nothing fails, nothing to act on
                self.log.debug("the robot (%s) went away between skills", service)
            self.driver.abort("robot_lost")

    def _refuse(self, action: Action, reason: str, detail: str) -> None:
        self.reject(action, reason, f"{action.decision_id}: {detail}")
        status = SkillStatus(
            decision_id=action.decision_id,
            skill=SKILL,
            state=SkillState.FAILED,
            reason=reason,
            detail=detail[:1024],
            stamp=time.time(),
        )
        self.call_soon(self.bus.publish, status)

    def _detail(self) -> str:
        if self.stopped.is_set():
            return f"emergency stop engaged: {self.stop_reason}"
        return self.last_error

    def publish_status(self, state: ServiceState, detail: str = "") -> None:
        if self.stopped.is_set() and state is ServiceState.OK:
            detail = self._detail()
        super().publish_status(state, detail)

    # --- worker thread ----------------------------------------------------------------------
    def _work(self) -> None:
        while not self.stop_event.is_set():
            try:
                action = self._actions.get(timeout=0.2)
            except queue.Empty:
                continue
            self.in_flight.begin(action.decision_id)
            self.driver.begin_decision(action.decision_id)  # before an end can name it
            self._running = action
            try:
                self._execute(action)
            except Exception:  # a bug in one action must not end the worker
                self.log.exception("action %s failed unexpectedly", action.decision_id)
            finally:
                self._running = None
                self.in_flight.end()

    def _execute(self, action: Action) -> None:
        if self.stopped.is_set():  # the stop came while it was queued or just taken
            self.reject(action, "stopped", f"{action.decision_id}: emergency stop engaged")
            self.in_flight.stop("emergency stop engaged")
            return
        episode = action.episode_id
        if not self.gate.may_be_next(episode):  # another episode started while it was queued
            self._refuse(action, "not_running_episode", episode)
            return
        scene = self.scenes.wait_for(
            episode,
            action.scene_sequence,
            self.scene_wait,
            give_up=lambda: not self.gate.may_be_next(episode),  # another episode started
        )
        if not self.gate.is_running(episode):  # the episode it waited for never came
            self._refuse(action, "not_running_episode", action.episode_id)
            return
        if self.gate.has_ended(action.episode_id):  # decided on a scene just before the end
            self._refuse(action, "episode_ended", f"{action.episode_id} has ended")
            return
        final = self.skill.execute(action, scene, self.in_flight.report)
        self.log.info(
            "%s %s -> %s: %s%s",
            action.decision_id,
            action.object_id,
            action.goal_id,
            final.state,
            f" ({final.reason}: {final.detail})" if final.reason else "",
        )

    def teardown(self) -> None:
        self.stop_event.set()
        self.driver.stop()  # a skill under way gives up instead of holding the shutdown
        self._worker.join(timeout=5.0)
        self.driver.close()
