"""When to decide: once per settled observation, never while a skill is still running."""

from __future__ import annotations

import time
from collections import OrderedDict

from manigraph_shared.messages import Action, EpisodeEvent, EpisodePhase, Scene, SkillStatus
from manigraph_planner.policies.base import Policy

_REMEMBERED = 1024


class DecisionMaker:
    """Turns scenes into actions for one policy.

    A decision is made on a scene only if no earlier decision is still executing and the scene
    was observed after the last skill ended (its stamp is later than that skill's terminal
    status), so the planner never acts twice on a stale world. Decision ids are
    ``<episode>:<step>``: the same log therefore drives a fresh planner to the same ids.
    """

    def __init__(self, policy: Policy) -> None:
        self.policy = policy
        self.episode_id: str | None = None
        self.step = 0
        self.pending: str | None = None
        self.ready_after = 0.0
        self._finished: OrderedDict[str, float] = OrderedDict()
        self._ended: OrderedDict[str, None] = OrderedDict()

    def on_episode(self, event: EpisodeEvent) -> None:
        if event.phase is EpisodePhase.END:
            _remember(self._ended, event.episode_id, None)
        elif event.episode_id != self.episode_id:
            self._start(event.episode_id)

    def on_status(self, status: SkillStatus) -> None:
        if not status.state.terminal:
            return
        _remember(self._finished, status.decision_id, status.stamp)
        if status.decision_id == self.pending:
            self.pending = None
            self.ready_after = status.stamp

    def on_scene(self, scene: Scene) -> Action | None:
        if scene.episode_id in self._ended:
            return None
        if scene.episode_id != self.episode_id:
            self._start(scene.episode_id)
        if self.pending is not None or scene.stamp <= self.ready_after:
            return None
        decision = self.policy.decide(scene)
        if decision is None:
            return None
        action = Action(
            decision_id=f"{scene.episode_id}:{self.step}",
            episode_id=scene.episode_id,
            scene_sequence=scene.sequence,
            object_id=decision.object_id,
            goal_id=decision.goal_id,
            orientation_index=decision.orientation_index,
            tray_action=decision.tray_action,
            policy=self.policy.name,
            stamp=time.time(),
        )
        self.step += 1
        self.pending = action.decision_id
        if action.decision_id in self._finished:  # its result overtook the decision (replay)
            self.pending = None
            self.ready_after = self._finished[action.decision_id]
        return action

    def _start(self, episode_id: str) -> None:
        self.episode_id = episode_id
        self.step = 0
        self.pending = None
        self.ready_after = 0.0


def _remember(store: OrderedDict, key: str, value: object) -> None:
    store[key] = value
    store.move_to_end(key)
    while len(store) > _REMEMBERED:
        store.popitem(last=False)
