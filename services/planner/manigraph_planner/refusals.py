"""What the skills refused in this episode, and until when the answer stands.

A skill that refuses a decision (``no_ik_solution``: the arm would flip; ``object_covered``: a
block lies on it) gives the same answer to the same question on the same world. The planner
remembers each refusal with a snapshot of the part of the world that could change the
answer, and does not ask the same question again until that part has changed.

Every reason the skills and the sims emit is of one of these kinds (an unknown one: ``pair``):

* **transient**: says nothing about the decision (the skills were busy, the episode or the
  robot was not there, the emergency stop, a driver that did not answer, a joint state that
  went stale): not remembered, the decision may be asked again at once;
* **retried**: ``recovery.RETRYABLE`` (a slipped grasp, a missed placement): the physics
  world may not repeat it; the progress monitor retries it, it is not remembered here;
* **object**: about the object whichever goal it was for (``object_covered``, an orientation
  the family cannot turn it to): every pair with the object is passed over;
* **goal**: about the goal whichever object (``slot_taken``, a closed rack): every pair with
  the goal is passed over;
* **pair**: about the pair (``no_ik_solution``, ``collision``, ``outside_workspace``,
  ``wrong_slot``, ...), and any reason not listed: that pair is passed over.

The **neighbourhood** of a refusal is the object, the goal, the goal's rack, and, unless the
reason is about reach alone (:data:`REACH`: ``no_ik_solution``, ``outside_workspace``, ...:
the arm's kinematics against the object's and the goal's poses), every object whose centre
lies within ``radius`` (horizontally) of the object's or the goal's. A refusal stands while
each of them is where it was (within ``tolerance``, same orientation, filled and visible
alike) and no other object came within ``radius``. A block taken off a covered one, a dish
set down beside a slot, a rack pulled out: each lets the question be asked again. What the
scene does not show is not compared: the arm's own joints (a ``no_ik_solution`` found from
another start would be asked again only once the object, slot or rack moved).

**A lesson**: once an ``object_covered`` refusal came, every object the scene shows covered
(another object resting on it: :class:`~manigraph_planner.scene_geometry.SceneGeometry`) is
passed over too, as long as it is covered, before the skills are asked: it would be refused
for the same reason. A lesson only orders the options: an episode never ends on one.
"""

from __future__ import annotations

import math
import zlib
from collections import Counter
from dataclasses import dataclass, field
from typing import Literal

from manigraph_planner.scene_geometry import SceneGeometry
from manigraph_shared.messages import Scene, SceneObject

Pair = tuple[str, str]
Scope = Literal["transient", "object", "goal", "pair"]

#: Refusals that say nothing about the decision refused (see the module docstring).
TRANSIENT = frozenset(
    {
        "skills_busy",
        "not_running_episode",
        "episode_ended",
        "unknown_scene",
        "no_scene",
        "no_episode",
        "stopped",
        "robot_lost",
        "driver_timeout",
        "start_mismatch",
    }
)
#: Refusals about the object, whichever goal it was taken to.
ABOUT_OBJECT = frozenset({"object_covered", "unknown_object", "orientation_unreachable"})
#: Refusals about the goal, whichever object was taken to it.
ABOUT_GOAL = frozenset({"unknown_goal", "slot_taken", "rack_closed", "top_rack_open"})
#: Refusals that depend on the object's, the goal's (and its rack's) poses alone: no
#: neighbour enters their neighbourhood.
REACH = frozenset(
    {
        "no_ik_solution",
        "outside_workspace",
        "limit_exceeded",
        "orientation_unreachable",
        "unknown_object",
        "unknown_goal",
        "wrong_slot",
    }
)
#: The refusal that teaches a lesson (see the module docstring).
COVERED = "object_covered"


def scope_of(reason: str) -> Scope:
    """What a refusal for ``reason`` is about (see the module docstring)."""
    if reason in TRANSIENT:
        return "transient"
    if reason in ABOUT_OBJECT:
        return "object"
    if reason in ABOUT_GOAL:
        return "goal"
    return "pair"


_State = tuple[float, ...]


@dataclass(frozen=True)
class Refusal:
    """One refused decision: its pair, the skills' reason, and its neighbourhood then."""

    pair: Pair
    reason: str
    scope: Scope
    step: int
    around: dict[str, _State] = field(default_factory=dict)
    #: For a lesson: the refusal it was learned from (then ``pair`` is ``(object, "*")``).
    learned_from: Refusal | None = None

    def covers(self, pair: Pair) -> bool:
        if self.scope == "object":
            return pair[0] == self.pair[0]
        if self.scope == "goal":
            return pair[1] == self.pair[1]
        return pair == self.pair

    def describe(self) -> str:
        """``object->goal: reason``, as an ``Action`` names the refusal it passes over (a
        lesson: ``object->*: reason, as <object->goal>``)."""
        said = f"{self.pair[0]}->{self.pair[1]}: {self.reason}"
        if self.learned_from is not None:
            said += f", as {self.learned_from.pair[0]}->{self.learned_from.pair[1]}"
        return said


class RefusalMemory:
    """The refusals of one episode that still stand (see the module docstring).

    Args:
        radius: metres (horizontal, centre to centre) within which an object is the
            neighbour of a refused object or goal.
        tolerance: metres a neighbour may move and still count as where it was.
        turn_tolerance: radians (5 degrees) a neighbour may turn and still count as it
            was: a measured scene (perception) jitters; with each quaternion component held
            to 1e-3, RGB-D poses had a refused pair asked again at every step (colour sort
            anywhere, seed 51125: ``no_ik_solution`` 7 times).
    """

    def __init__(
        self, radius: float = 0.1, tolerance: float = 0.005, turn_tolerance: float = 0.087
    ) -> None:
        if not radius >= 0:
            raise ValueError(f"radius: must be >= 0 metres, got {radius}")
        if not tolerance >= 0:
            raise ValueError(f"tolerance: must be >= 0 metres, got {tolerance}")
        self.radius = radius
        self.tolerance = tolerance
        self.turn_tolerance = turn_tolerance
        self.reset()

    def reset(self) -> None:
        self._standing: list[Refusal] = []
        self._taught: list[Refusal] = []  # every refusal remembered this episode
        #: Every refusal of the episode by reason (transient ones too), for its summary.
        self.counts: Counter[str] = Counter()

    def on_refusal(self, scene: Scene, pair: Pair, reason: str, step: int) -> Refusal | None:
        """Remember that the skills refused ``pair``, decided on ``scene``, for ``reason``;
        returns the refusal remembered (None: transient, nothing to remember)."""
        self.counts[reason] += 1
        scope = scope_of(reason)
        if scope == "transient":
            return None
        refusal = Refusal(pair, reason, scope, step, self._neighbourhood(scene, pair, reason))
        self._standing = [r for r in self._standing if r.pair != pair or r.reason != reason]
        self._standing.append(refusal)
        self._taught.append(refusal)
        return refusal

    def standing(self, scene: Scene) -> list[Refusal]:
        """The refusals whose neighbourhood ``scene`` leaves unchanged (the others are
        forgotten: the world changed in a way that could change their answer)."""
        self._standing = [r for r in self._standing if not self._changed(r, scene)]
        return list(self._standing)

    def lessons(self, scene: Scene) -> list[Refusal]:
        """Objects ``scene`` shows covered, once the skills refused one as covered."""
        taught = next((r for r in reversed(self._taught) if r.reason == COVERED), None)
        if taught is None or not scene.objects:
            return []
        geometry = SceneGeometry(scene)
        return [
            Refusal((o.id, "*"), COVERED, "object", taught.step, learned_from=taught)
            for o in scene.objects
            if geometry.is_covered(o)
        ]

    def _neighbourhood(self, scene: Scene, pair: Pair, reason: str) -> dict[str, _State]:
        states = _states(scene)
        keys = self._keys(scene, pair, 0.0 if reason in REACH else self.radius)
        return {key: states[key] for key in keys if key in states}

    def _keys(self, scene: Scene, pair: Pair, radius: float) -> set[str]:
        """The entities whose state could change the answer to ``pair`` on ``scene``."""
        object_id, goal_id = pair
        keys = {f"o:{object_id}", f"g:{goal_id}"}
        centres = []
        item = _find(scene.objects, object_id)
        if item is not None:
            centres.append((item.position.x, item.position.y))
        goal = _find(scene.goals, goal_id)
        if goal is not None:
            centres.append((goal.position.x, goal.position.y))
            if goal.fixture is not None:
                keys.add(f"f:{goal.fixture}")
        if radius <= 0:
            return keys
        r2 = radius * radius
        for other in scene.objects:
            p = other.position
            if any((p.x - x) ** 2 + (p.y - y) ** 2 <= r2 for x, y in centres):
                keys.add(f"o:{other.id}")
        return keys

    def _changed(self, refusal: Refusal, scene: Scene) -> bool:
        states = _states(scene)
        radius = 0.0 if refusal.reason in REACH else self.radius
        keys = self._keys(scene, refusal.pair, radius) | refusal.around.keys()
        for key in keys:
            then, now = refusal.around.get(key), states.get(key)
            if then is None or now is None:
                if then is not now:
                    return True
                continue
            if max(abs(a - b) for a, b in zip(then[:3], now[:3], strict=True)) > self.tolerance:
                return True
            turned = key[0] in "og" and _angle(then[3:7], now[3:7]) > self.turn_tolerance
            flags = then[7:] if key[0] in "og" else then[3:]
            news = now[7:] if key[0] in "og" else now[3:]
            if turned or len(flags) != len(news):
                return True
            if flags and max(abs(a - b) for a, b in zip(flags, news, strict=True)) > 1e-3:
                return True
        return False


def _find(items, name: str):  # objects or goals, by id
    return next((i for i in items if i.id == name), None)


def _states(scene: Scene) -> dict[str, _State]:
    """Each object's, goal's and fixture's state: position, then orientation and flags (a
    fixture: its state)."""
    states: dict[str, _State] = {}
    for o in scene.objects:
        states[f"o:{o.id}"] = (*_position(o), *_turn(o), float(o.filled), float(o.visible))
    for g in scene.goals:
        q = g.orientation
        states[f"g:{g.id}"] = (
            g.position.x,
            g.position.y,
            g.position.z,
            q.x,
            q.y,
            q.z,
            q.w,
            float(g.filled),
            float(g.visible),
        )
    for f in scene.fixtures:  # its state's values, by name (a text as a number of its own)
        values = (_scalar(value) for _, value in sorted(f.state.items()))
        states[f"f:{f.id}"] = (f.position.x, f.position.y, f.position.z, *values)
    return states


def _scalar(value: bool | float | str) -> float:
    """A fixture's state value as a number that changes when it does."""
    return float(zlib.crc32(value.encode())) if isinstance(value, str) else float(value)


def _angle(a: tuple[float, ...], b: tuple[float, ...]) -> float:
    """Radians of the turn between two orientations (quaternions x, y, z, w)."""
    dot = abs(sum(x * y for x, y in zip(a, b, strict=True)))
    norms = math.sqrt(sum(x * x for x in a) * sum(y * y for y in b)) or 1.0
    return 2.0 * math.acos(min(1.0, dot / norms))


def _position(o: SceneObject) -> tuple[float, float, float]:
    return (o.position.x, o.position.y, o.position.z)


def _turn(o: SceneObject) -> tuple[float, float, float, float]:
    q = o.orientation
    return (q.x, q.y, q.z, q.w)
