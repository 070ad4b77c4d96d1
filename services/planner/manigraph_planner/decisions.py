"""When to decide: once per settled observation, never while a skill is still running."""

from __future__ import annotations

import threading
import time
from collections import OrderedDict
from collections.abc import Callable

import msgspec

from manigraph_planner.policies.base import Decision, Policy
from manigraph_planner.recovery import ProgressMonitor, Verdict
from manigraph_shared.decision_failure import OUT_OF_OPTIONS, CannotDecide
from manigraph_shared.errors import PolicyError
from manigraph_shared.messages import Action, EpisodeEvent, EpisodePhase, Scene, SkillStatus

_REMEMBERED = 1024
_HELD = 256
#: After skills refused a decision because the robot is stopped, seconds of scenes the planner
#: lets pass before it decides again: a planner that has not (yet) heard the stop asks at most
#: once a second instead of once per refusal (thousands a second).
STOPPED_BACKOFF = 1.0
#: Decisions whose scenes are kept so they can be explained afterwards.
KEPT_DECISIONS = 64


class OutOfOptions(CannotDecide):
    """Every pair the policy ranks was refused by the skills on the world as it still is:
    asking again would be refused again, so the episode ends, naming its refusals."""


class DecisionHistory:
    """The last ``capacity`` decisions with the scene each was made on (for the explainer).

    Written by the service thread, read by the explain queryable on a Zenoh thread: a lock
    keeps the two consistent.
    """

    def __init__(self, capacity: int = KEPT_DECISIONS) -> None:
        if capacity < 1:
            raise ValueError(f"capacity: must be >= 1, got {capacity}")
        self.capacity = capacity
        self._items: OrderedDict[str, tuple[Scene, Action]] = OrderedDict()
        self._lock = threading.Lock()

    def add(self, scene: Scene, action: Action) -> None:
        with self._lock:
            self._items[action.decision_id] = (scene, action)
            self._items.move_to_end(action.decision_id)
            while len(self._items) > self.capacity:
                self._items.popitem(last=False)

    def get(self, decision_id: str) -> tuple[Scene, Action] | None:
        with self._lock:
            return self._items.get(decision_id)

    def latest(self) -> tuple[Scene, Action] | None:
        with self._lock:
            return next(reversed(self._items.values()), None)

    def ids(self) -> list[str]:
        with self._lock:
            return list(self._items)


class DecisionMaker:
    """Turns scenes into actions for one policy.

    A decision is made on a scene only if no earlier decision is still executing and the scene
    was observed after the last skill ended (its stamp is later than that skill's terminal
    status), so the planner never acts twice on a stale world. Scenes and statuses come from
    different publishers and may arrive in either order, so scenes seen while a skill runs are
    kept, and the earliest one observed after the skill ended is decided on as soon as its
    status arrives: the choice depends on stamps, never on arrival order. Decision ids are
    ``<episode>:<step>``; the same log therefore drives a fresh planner to the same decisions.

    Recovery: a decision that made no progress (see :mod:`manigraph_planner.recovery`) is not
    taken again on the same world; the policy's next most likely compatible pair is, and the
    ``Action`` says so (``rank``, ``recovery``). Wherever progress is made the decision is the
    policy's own. A decision the skills refused is not asked again until something near it
    moved (``recovery = "refused"``, ``passed_over`` naming it); when every ranked pair was
    refused so, the episode ends: :class:`OutOfOptions` (the service reports it like
    :class:`CannotDecide`; the run client ends that episode with reason ``out_of_options: ...``).
    """

    def __init__(
        self,
        policy: Policy,
        *,
        clock: Callable[[], float] = time.time,
        decision_timeout: float = 30.0,
        progress: ProgressMonitor | None = None,
    ) -> None:
        if not decision_timeout > 0:
            raise ValueError(f"decision_timeout: must be > 0 seconds, got {decision_timeout}")
        self.policy = policy
        self.clock = clock
        self.decision_timeout = decision_timeout
        self.progress = progress or ProgressMonitor(object_escalation=policy.object_escalation)
        self.episode_id: str | None = None
        self.step = 0
        self.pending: str | None = None
        self.pending_since = 0.0  # time.monotonic() when the pending decision was sent
        #: Emergency stop engaged: no decision until it is released.
        self.stopped = False
        self.ready_after = 0.0
        self._held: list[Scene] = []  # scenes that arrived while a skill ran
        self._finished: OrderedDict[str, SkillStatus] = OrderedDict()
        self._ended: OrderedDict[str, None] = OrderedDict()
        self.history = DecisionHistory()

    def on_episode(self, event: EpisodeEvent) -> None:
        if event.phase is EpisodePhase.END:
            _remember(self._ended, event.episode_id, None)
        elif event.episode_id != self.episode_id:
            self._start(event.episode_id)

    def on_status(self, status: SkillStatus) -> Action | None:
        if not status.state.terminal:
            return None
        _remember(self._finished, status.decision_id, status)
        if status.decision_id != self.pending:
            return None
        self.progress.on_status(status)
        self.pending = None
        self.ready_after = status.stamp
        if status.reason == "stopped":  # the robot is stopped, whatever this planner heard
            self.ready_after += STOPPED_BACKOFF
            self._held.clear()
            return None
        return self._decide_on_held()

    def give_up(self, now: float, skills_alive: bool = True) -> str | None:
        """Forget a decision whose skill will never report; returns why (or None).

        ``skill_timeout``: no final status within ``decision_timeout`` seconds of
        ``time.monotonic()`` ``now``; ``skills_lost``: the skills service went away while it ran.
        The next scene observed after now is decided on, so a planner never waits forever on
        a lost decision (the run client fails the episode; see ``manigraph_tools.episodes``).
        """
        if self.pending is None:
            return None
        if skills_alive and now - self.pending_since < self.decision_timeout:
            return None
        self.pending = None
        self._held.clear()
        self.ready_after = self.clock()
        return "skills_lost" if not skills_alive else "skill_timeout"

    def on_stop(self, engaged: bool) -> None:
        """Emergency stop: decide nothing while engaged; after release, the next scene."""
        self.stopped = engaged
        self._held.clear()

    def on_scene(self, scene: Scene) -> Action | None:
        if self.stopped:
            return None
        if scene.episode_ended:  # said by the world itself: no race with the end event
            _remember(self._ended, scene.episode_id, None)
        if scene.episode_id in self._ended:
            return None
        if scene.episode_id != self.episode_id:
            self._start(scene.episode_id)
        if self.pending is not None:
            self._held.append(scene)
            del self._held[:-_HELD]
            return None
        if scene.stamp <= self.ready_after:
            return None
        return self._decide(scene)

    def _decide_on_held(self) -> Action | None:
        fresh = [s for s in self._held if s.stamp > self.ready_after]
        self._held.clear()
        if self.stopped or not fresh or fresh[0].episode_id in self._ended:
            return None
        return self._decide(min(fresh, key=lambda s: (s.stamp, s.sequence)))

    def _choose(self, scene: Scene) -> tuple[Decision | None, int, str | None, str | None]:
        """The policy's decision, or its best alternative that is not passed over; with its
        rank, why the decision was passed over and the refusal passed over (if one was)."""
        decision = self.policy.decide(scene)
        verdict = self.progress.verdict(scene)
        if decision is None or verdict.allows(decision.pair):
            return decision, 0, None, None
        refusal = verdict.refusal(decision.pair)
        passed_over = refusal.describe() if refusal is not None else None
        ranked = self.policy.ranked(scene)
        for rank, alternative in enumerate(ranked):
            if verdict.allows(alternative.pair):
                return alternative, rank, verdict.why(decision.pair), passed_over
        if refusal is None:  # nothing says it would be refused: the first choice again
            return decision, 0, "exhausted", None
        for lessons in (True, False):  # the best one not refused, nor (first) predicted to be
            for rank, alternative in enumerate(ranked):
                if verdict.refusal(alternative.pair, lessons) is None:
                    return alternative, rank, "exhausted", passed_over
        raise OutOfOptions(scene.episode_id, _out_of_options(verdict, self.progress))

    def _decide(self, scene: Scene) -> Action | None:
        try:
            decision, rank, recovery, passed_over = self._choose(scene)
        except OutOfOptions:
            _remember(self._ended, scene.episode_id, None)
            raise
        except PolicyError as exc:
            # The policy cannot read this episode's world (a value its vocabulary never saw):
            # every later scene of it would be refused the same way, 10 a second. Refuse the
            # episode once instead; the run client ends it (manigraph_shared.decision_failure).
            _remember(self._ended, scene.episode_id, None)
            raise CannotDecide(scene.episode_id, str(exc)) from None
        if decision is None:
            return None
        action = decision.to_action(
            scene, self.step, self.policy.name, self.clock(), rank=rank, recovery=recovery
        )
        if passed_over is not None:
            action = msgspec.structs.replace(action, passed_over=passed_over[:256])
        self.progress.on_decision(scene, decision.pair)
        self.step += 1
        self.history.add(scene, action)
        self.pending = action.decision_id
        self.pending_since = time.monotonic()
        if action.decision_id in self._finished:  # its result overtook the decision (replay)
            self.pending = None
            self.ready_after = self._finished[action.decision_id].stamp
            self.progress.on_status(self._finished[action.decision_id])
        return action

    def _start(self, episode_id: str) -> None:
        self.episode_id = episode_id
        self.step = 0
        self.pending = None
        self.ready_after = 0.0
        self._held.clear()
        self.progress.reset()


def _out_of_options(verdict: Verdict, progress: ProgressMonitor) -> str:
    """``out_of_options: <n> pairs refused (<reason> x<count>, ...)``: the episode's refusals
    by reason, most first."""
    counts = progress.refusals.counts.most_common()
    named = ", ".join(f"{reason} x{count}" for reason, count in counts)
    return f"{OUT_OF_OPTIONS}: {len(verdict.refused)} refusals stand ({named})"[:512]


def _remember(store: OrderedDict, key: str, value: object) -> None:
    store[key] = value
    store.move_to_end(key)
    while len(store) > _REMEMBERED:
        store.popitem(last=False)
