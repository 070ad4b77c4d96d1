"""A task family's part of the skill runner, as one registered unit (docs/architecture.md).

The skill runner (:class:`~manigraph_skills.pick_and_place.PickAndPlace`) moves any object to
any goal the same way; what a family adds is named here, in the ``skills`` part of its package
(``families/<name>/``, docs/families.md), which names its :class:`SkillFamily` in the
package's ``manigraph.families`` entry point (:mod:`manigraph_shared.family_packages`);
:data:`FAMILIES` registers every installed one, by name, when it is first read. The runner
asks the registry rather than which family a scene is:

* **actions** of its own, beside PickAndPlace (a fixture it opens or closes):
  :meth:`SkillFamily.takes` says whether an action is one, ``run_action`` runs it;
* **rules** a robot whose world refuses nothing checks before moving
  (``check_move``, for a driver with ``checks_family_rules``);
* **where to set an object down** in a goal (``set_down_point``; default: the goal's point);
* **obstacles** of its fixtures the arm must avoid (box walls, rack floors);
* **turn-over**: the manoeuvre a driver with a real arm tilts an object over with, composed
  of the :class:`~manigraph_skills.drivers.panda_motion.PandaMotionDriver`'s public pieces
  (``run_plan``, ``release``, ``put_back``, ``raise_if_stopped``, ``pick_at``).

Each hook is ``"module:attribute"``, imported when first used (the family's modules import
the skill runner's, so registering stays free of cycles).
"""

from __future__ import annotations

from collections.abc import Callable, Iterator
from dataclasses import dataclass
from typing import Any

from manigraph_shared.family_packages import check_one_fallback, family_of_scene, register_parts
from manigraph_shared.messages import Action, Scene
from manigraph_shared.registry import Registry, import_target

__all__ = ["FAMILIES", "SkillFamily", "family_of", "family_taking", "register_family"]


def _no_action(action: Action) -> bool:
    return False


def _any_scene(scene: Scene) -> bool:
    return True


@dataclass(frozen=True)
class SkillFamily:
    """One task family's skill extensions.

    Args:
        name: the family (its entry point's name), as in the sim's and planner's.
        matches: whether a scene is this family's (what the scene itself shows).
        fallback: the family of every scene no other matches (blocks).
        takes: whether an action is one of this family's own (not a PickAndPlace).
        run_action: ``(runner, action, scene, status) -> None``, runs such an action.
        check_move: ``(scene, item, goal) -> None``, raises ``SkillError`` for a move the
            family's rules refuse (checked for a driver with ``checks_family_rules``).
        set_down_point: ``(scene, item, goal) -> Vector3``; None: the goal's position.
        obstacles: ``(scene, moving, at) -> list[Obstacle]`` of its fixtures.
        turn_over: ``(driver, decision_id, item, wanted, scene) -> SceneObject``, the
            PandaMotionDriver's turn-over manoeuvre.
    """

    name: str
    matches: Callable[[Scene], bool] = _any_scene
    fallback: bool = False
    takes: Callable[[Action], bool] = _no_action
    run_action: str | None = None
    check_move: str | None = None
    set_down_point: str | None = None
    obstacles: str | None = None
    turn_over: str | None = None
    help: str = ""

    def part(self, name: str) -> Any:
        """The hook ``name`` imported, or None when the family has none."""
        path = getattr(self, name)
        return None if path is None else import_target(path)


def _register_installed() -> None:
    """Register the ``skills`` part of every installed family package, by family name."""
    register_parts("skills", SkillFamily, register_family)


#: Every task family the skill runner knows, by name: the installed family packages' are
#: registered when it is first read.
FAMILIES: Registry[SkillFamily] = Registry("family", fill=_register_installed)


def register_family(family: SkillFamily) -> SkillFamily:
    """Add ``family`` to :data:`FAMILIES`; a second fallback family is refused."""
    check_one_fallback(family, families())
    FAMILIES.add(family.name, family, help=family.help)
    return family


def families() -> Iterator[SkillFamily]:
    """Every registered family, by name (the installed packages'), then any registered
    later."""
    for _, family in FAMILIES.items():
        yield family


def family_of(scene: Scene) -> SkillFamily:
    """The family ``scene`` belongs to: the first that matches it, else the fallback."""
    return family_of_scene(families(), scene)


def family_taking(action: Action) -> SkillFamily | None:
    """The family whose own action ``action`` is (an action of its own), or None:
    a PickAndPlace."""
    return next((family for family in families() if family.takes(action)), None)
