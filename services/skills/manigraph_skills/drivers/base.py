"""What a skill needs from a robot: grasp an object at a pose, release it at another.

A driver implements :meth:`RobotDriver.pick` and :meth:`RobotDriver.place`, each taking one
:class:`Motion`, and may implement :meth:`RobotDriver.toggle_tray`, taking one
:class:`TrayToggle`; what each says is declared once, there. Drivers are registered by name
with their options in ``manigraph_skills.drivers.registry``.
"""

from __future__ import annotations

import math
from abc import ABC, abstractmethod
from dataclasses import dataclass
from typing import Any

from manigraph_shared.errors import SkillError
from manigraph_shared.messages import Quaternion, Scene, SceneObject, Vector3
from manigraph_skills.obstacles import Obstacle

#: Refusals that come from planning, before the robot moved: a held object is put back, and
#: another way of doing the same motion may be tried.
PLANNING_FAILURES = frozenset({"collision", "no_ik_solution"})


@dataclass(frozen=True)
class Grasp:
    """How to hold an object, chosen by the skill from the scene (``grasp_choice``); a
    driver without fingers to place (the geometric world's magic gripper) ignores it."""

    height: float = 0.0  # TCP above the object's centre, metres (a cover: at its handle)
    turn: float = 0.0  # hand yaw added to the driver's default, radians
    carry_z: float = 0.0  # lowest TCP height for carrying the object across, metres
    #: What the arm must not touch on the way (a driver that plans arm motion checks it).
    obstacles: tuple[Obstacle, ...] = ()
    #: The other hand yaw (added to ``turn``) the object may be held at, radians: a quarter
    #: turn for a square block or cover, a half turn for a plate taken across its thickness.
    other_turn: float = math.pi / 2
    #: How far apart the fingers open around it, metres; None: fully (``grasp_choice``).
    opening: float | None = None


#: A block's grasp at its centre, the driver's default yaw and carry heights.
CENTRE_GRASP = Grasp()


@dataclass(frozen=True)
class Motion:
    """One pick or one place of decision ``decision_id``: ``object_id`` is grasped with its
    centre at ``position`` (a pick), or carried so its centre ends at ``position`` and
    released (a place); ``orientation`` is the object's (pick) or the goal's (place)."""

    decision_id: str
    object_id: str
    position: Vector3
    orientation: Quaternion
    grasp: Grasp = CENTRE_GRASP


@dataclass(frozen=True)
class TrayToggle:
    """One rack toggle of decision ``decision_id``: grasp rack ``rack_id``'s handle (reported
    at ``handle``) by its tab, ``grip`` from there (x, y, z, metres), and push the rack in if
    ``is_open``, else pull it out (a family's own action). ``rail``: how far it slides out all
    the way, metres; ``travel``: how far it is out now, where the scene measured it (None: all
    the way if open, else not at all). The family that owns the rack says where its tab is and
    how long its rail (what the scene leaves unsaid)."""

    decision_id: str
    rack_id: str
    handle: Vector3
    is_open: bool
    rail: float
    grip: tuple[float, float, float]
    travel: float | None = None


class RobotDriver(ABC):
    """Raises ``SkillError(reason)`` when the robot could not do what was asked.

    :meth:`stop` is the emergency stop: it is called from another thread while ``pick`` or
    ``place`` may be running, must return at once, and makes the running call (and every call
    until :meth:`resume`) raise ``SkillError("stopped")``.
    """

    name: str
    #: Whether the skill checks the scene's family's rules (``SkillFamily.check_move``) on the
    #: scene before moving this robot: a physical fixture refuses nothing by itself. The
    #: geometric world refuses by the same rules, so its driver leaves them to it.
    checks_family_rules: bool = False

    @classmethod
    def from_options(cls, bus: Any, options: Any) -> RobotDriver:
        """The driver on ``bus`` configured by its registered options (or None: it has none)."""
        return cls()

    @abstractmethod
    def pick(self, motion: Motion) -> None:
        """Grasp the object and lift it clear."""

    @abstractmethod
    def place(self, motion: Motion) -> None:
        """Carry the held object to the motion's position and release it."""

    def toggle_tray(self, toggle: TrayToggle) -> None:
        """Push the rack in or pull it out as ``toggle`` says. A driver that cannot refuses
        with reason ``unsupported``."""
        name = getattr(self, "name", type(self).__name__)
        raise SkillError("unsupported", f"the {name} driver cannot toggle a tray yet")

    def check_orientation(self, object_id: str, current: Quaternion, target: Quaternion) -> None:
        """Refuse (``orientation_unreachable``) before any motion if this robot cannot turn
        ``object_id`` from ``current`` to ``target`` as it places it; a magic gripper can."""

    def turn_over(
        self, decision_id: str, item: SceneObject, target: Quaternion, scene: Scene
    ) -> SceneObject:
        """Turn ``item`` so its up axis is ``target``'s before it is picked, and return it as
        it then lies; a robot that turns an object as it places it (a magic gripper) leaves
        it as it is."""
        return item

    @abstractmethod
    def stop(self) -> None:
        """Halt now (emergency stop): abort the motion under way, refuse new ones."""

    @abstractmethod
    def resume(self) -> None:
        """Accept motions again after :meth:`stop`."""

    def abort(self, reason: str) -> None:
        """The robot went away (its process died): fail the motion under way now with
        ``reason`` instead of waiting for an answer that cannot come. Not sticky."""

    def begin_decision(self, decision_id: str) -> None:
        """``decision_id`` starts now (before any :meth:`end_decision` can name it): whatever
        was known of an earlier decision of that id (a log replayed, an episode id used
        again) no longer applies."""

    def end_decision(self, decision_id: str, reason: str) -> None:
        """The world ended ``decision_id``'s episode: send nothing more for it, not even a
        re-plan, and fail its motion under way with ``reason``. (A driver that finishes a
        decision in one call has nothing to do.)"""

    def close(self) -> None:
        """Release the driver's resources."""
