"""Recovery from decisions that made no progress.

A policy that decides on the world alone takes the same decision on the same world: if the
skill changed nothing (a covered block that cannot be lifted, a block that falls back where it
was), the episode repeats one decision until its step budget runs out. :class:`ProgressMonitor`
watches the decisions of one episode and says which (object, goal) pairs to pass over on the
next scene, so the planner takes the policy's next most likely compatible pair instead.

A decision made **no progress** when

* the world after it equals the world before it (every object within ``tolerance`` of where
  it was, the same objects and goals filled and visible), or
* its (object, goal) pair was chosen before in this episode and no goal has been filled since
  (a block carried back and forth, a goal that never holds).

A failure the world may not repeat (``grasp_slipped``, ``placement_missed``: the physics world's
fingers or placement) is retried ``retries`` times before it counts as no progress. Pairs that
made no progress are passed over until the world changes (the first rule) or a goal is filled
(the second). Escalation: once two pairs with the same object (or the same goal) made no
progress, every pair with that object (goal) is passed over (for objects, after
``object_escalation`` pairs: a policy may say one, where a failure belongs to the object
whichever goal it was for). Wherever progress is made, nothing
is passed over, so the policy's decisions are exactly its own.

A decision the skills **refused** is remembered apart (:mod:`manigraph_planner.refusals`): it
is passed over until the object, the goal or their neighbourhood changes, however much the
rest of the world moves or how many goals are filled, and a transient refusal (the skills
busy, the stop) is neither remembered nor counted as no progress.
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass, field

from manigraph_planner.refusals import Refusal, RefusalMemory, scope_of
from manigraph_shared.messages import Scene, SkillState, SkillStatus

Pair = tuple[str, str]

#: Skill failures that a second attempt of the same decision may not repeat.
RETRYABLE = frozenset({"grasp_slipped", "placement_missed"})


@dataclass(frozen=True)
class Verdict:
    """What to pass over on a scene, and why (``None``: nothing, the policy decides freely)."""

    pairs: frozenset[Pair] = frozenset()
    objects: frozenset[str] = frozenset()
    goals: frozenset[str] = frozenset()
    stalled: frozenset[Pair] = frozenset()
    refused: tuple[Refusal, ...] = ()
    lessons: tuple[Refusal, ...] = ()

    def allows(self, pair: Pair) -> bool:
        return (
            pair not in self.pairs
            and pair[0] not in self.objects
            and pair[1] not in self.goals
            and self.refusal(pair) is None
        )

    def refusal(self, pair: Pair, lessons: bool = True) -> Refusal | None:
        """The standing refusal that ``pair`` would be asked again against, if any (with
        ``lessons``: or the lesson that predicts one)."""
        found = next((r for r in self.refused if r.covers(pair)), None)
        if found is None and lessons:
            found = next((r for r in self.lessons if r.covers(pair)), None)
        return found

    def why(self, pair: Pair) -> str:
        """Why ``pair`` is passed over: the world did not change after it (``no_progress``),
        it was chosen before and no goal filled since (``repeated_pair``), or two pairs with
        its object or goal made no progress (``escalated``); before these, the skills refused
        it and nothing near it moved since (``refused``)."""
        if self.refusal(pair) is not None:
            return "refused"
        if pair in self.stalled:
            return "no_progress"
        if pair in self.pairs:
            return "repeated_pair"
        return "escalated"


@dataclass
class _Attempt:
    pair: Pair
    scene: Scene
    filled: frozenset[str]
    step: int = 0
    status: SkillStatus | None = None


@dataclass
class _Stalls:
    """Pairs that made no progress on one world (cleared when the world changes)."""

    world: Scene | None = None
    pairs: set[Pair] = field(default_factory=set)


class ProgressMonitor:
    """No-progress detection for the decisions of one episode (see the module docstring).

    Args:
        tolerance: metres an object may move and still count as "where it was".
        retries: attempts of a decision that failed for a :data:`RETRYABLE` reason before
            the same decision counts as no progress.
        object_escalation: pairs with one object that made no progress before every pair
            with it is passed over.
    """

    def __init__(
        self,
        tolerance: float = 0.005,
        retries: int = 2,
        object_escalation: int = 2,
        refusals: RefusalMemory | None = None,
    ) -> None:
        if tolerance < 0:
            raise ValueError(f"tolerance: must be >= 0, got {tolerance}")
        if retries < 0:
            raise ValueError(f"retries: must be >= 0, got {retries}")
        if object_escalation < 1:
            raise ValueError(f"object_escalation: must be >= 1, got {object_escalation}")
        self.tolerance = tolerance
        self.retries = retries
        self.object_escalation = object_escalation
        self.refusals = refusals if refusals is not None else RefusalMemory(tolerance=tolerance)
        self.reset()

    def reset(self) -> None:
        self._last: _Attempt | None = None
        self._chosen: dict[Pair, frozenset[str]] = {}  # pair -> goals filled when last chosen
        self._stalls = _Stalls()
        self._retried = 0
        self._steps = 0
        self.refusals.reset()

    def on_decision(self, scene: Scene, pair: Pair) -> None:
        filled = _filled_goals(scene)
        if self._last is not None and self._last.pair == pair and self._retryable(self._last):
            self._retried += 1
        else:
            self._retried = 0
        self._last = _Attempt(pair, scene, filled, self._steps)
        self._steps += 1
        self._chosen[pair] = filled

    def on_status(self, status: SkillStatus) -> None:
        last = self._last
        if last is None or not status.state.terminal or last.status is not None:
            return
        last.status = status
        if status.state is SkillState.FAILED:
            reason = status.reason or "unknown"
            if reason in RETRYABLE:  # retried as before, counted only
                self.refusals.counts[reason] += 1
            else:
                self.refusals.on_refusal(last.scene, last.pair, reason, last.step)

    def verdict(self, scene: Scene) -> Verdict:
        """Which pairs to pass over when deciding on ``scene`` (the scene after the last
        decision's skill ended)."""
        last = self._last
        if last is None:
            return Verdict()
        retry = (self._retryable(last) and self._retried < self.retries) or self._transient(last)
        if self._stalls.world is not None and not self.same_world(self._stalls.world, scene):
            self._stalls = _Stalls()
        if not retry and self.same_world(last.scene, scene):
            self._stalls.world = scene
            self._stalls.pairs.add(last.pair)
        filled = _filled_goals(scene)
        repeats = {pair for pair, then in self._chosen.items() if not (filled - then)}
        if retry:
            repeats.discard(last.pair)
        stalled = frozenset(self._stalls.pairs)
        passed = stalled | repeats
        return Verdict(
            pairs=frozenset(passed),
            objects=_escalated(passed, 0, self.object_escalation),
            goals=_escalated(passed, 1),
            stalled=stalled,
            refused=tuple(self.refusals.standing(scene)),
            lessons=tuple(self.refusals.lessons(scene)),
        )

    def same_world(self, before: Scene, after: Scene) -> bool:
        """Every object within ``tolerance`` of where it was; the same goals filled and the
        same nodes visible."""
        old = {o.id: o for o in before.objects}
        if old.keys() != {o.id for o in after.objects}:
            return False
        for o in after.objects:
            p, q = old[o.id].position, o.position
            if max(abs(p.x - q.x), abs(p.y - q.y), abs(p.z - q.z)) > self.tolerance:
                return False
            if (o.filled, o.visible) != (old[o.id].filled, old[o.id].visible):
                return False
        goals = {g.id: (g.filled, g.visible) for g in before.goals}
        return goals == {g.id: (g.filled, g.visible) for g in after.goals}

    @staticmethod
    def _transient(attempt: _Attempt) -> bool:
        """Refused for a reason that says nothing about the decision: ask it again."""
        status = attempt.status
        return (
            status is not None
            and status.state is SkillState.FAILED
            and scope_of(status.reason or "unknown") == "transient"
        )

    @staticmethod
    def _retryable(attempt: _Attempt) -> bool:
        status = attempt.status
        return (
            status is not None
            and status.state is SkillState.FAILED
            and (status.reason or "") in RETRYABLE
        )


def _filled_goals(scene: Scene) -> frozenset[str]:
    return frozenset(g.id for g in scene.goals if g.filled)


def _escalated(pairs: Iterable[Pair], side: int, after: int = 2) -> frozenset[str]:
    """Objects (side 0) or goals (side 1) that appear in ``after`` or more passed-over
    pairs."""
    seen: dict[str, int] = {}
    for pair in pairs:
        seen[pair[side]] = seen.get(pair[side], 0) + 1
    return frozenset(name for name, count in seen.items() if count >= after)
