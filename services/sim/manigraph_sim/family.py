"""A task family: one registered unit that owns a kind of world, as ManiSkill's task class owns
its scene and its ``evaluate()``.

A family owns

* its **layout type** (``layout_type``: what its tasks lay out, a :class:`Layout` subclass);
* its **tasks** (registered in ``TASKS`` by its own folder) and its **options**
  (``FAMILIES`` entry options: :class:`~manigraph_shared.options.Options` built from the
  episode request, refusing another family's field);
* its **success check** (:meth:`SimFamily.evaluate`: the one place that says which goals are
  filled, how many there are, how many hold an object they do not accept, and whether that is
  success);
* its **world adapters**: :meth:`SimFamily.geometric_world` for the geometric backend and
  :meth:`SimFamily.physics_world` for the physics backend (optional: without one the
  physics backend refuses the family's episodes). A backend holds the adapter and
  nothing family-specific: it never asks which family a layout is.

Each family is a package of its own (``families/<name>/`` at the repository root,
docs/families.md) whose ``sim`` part is laid out the same way (``family.py`` the unit, its
tasks, its geometric world, its ``scene.py``, its ``physics.py``). The package names its
:class:`SimFamily` subclass in its ``manigraph.families`` entry point
(:mod:`manigraph_shared.family_packages`); :data:`FAMILIES` registers every installed one,
by name, when it is first read. The sim reaches a family only through this module.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, ClassVar

from manigraph_shared.errors import ConfigError
from manigraph_shared.family_packages import register_parts
from manigraph_shared.messages import EpisodeRequest, RobotCommand, Scene
from manigraph_shared.registry import Registry
from manigraph_sim.tasks.base import TASKS, Task
from manigraph_sim.world_model import Body, Layout

if TYPE_CHECKING:
    from manigraph_sim.physics.physics_world import PhysicsWorld

__all__ = [
    "FAMILIES",
    "Evaluation",
    "GeometricTaskWorld",
    "PhysicsTaskWorld",
    "SimFamily",
    "family_of",
    "register_family",
    "task_file_family",
]

#: The worlds whose geometry a family lays its tasks out in (a backend says which).
GEOMETRIES = ("geometric", "physics")


@dataclass(frozen=True)
class Evaluation:
    """How an episode stands by its family's rule: which of its ``required`` goals are
    ``filled_goals``, whether that is success, and the goals holding an object they do not
    accept (``wrong_object_goals``)."""

    required: frozenset[str]
    filled_goals: frozenset[str]
    success: bool
    wrong_object_goals: frozenset[str] = frozenset()
    #: Placements into a goal the judge's rules do not accept (0 without rules).
    rule_violations: int = 0

    @property
    def filled(self) -> int:
        return len(self.filled_goals)

    @property
    def total(self) -> int:
        return len(self.required)

    @property
    def wrong_object(self) -> int:
        """How many goals hold an object they do not accept."""
        return len(self.wrong_object_goals)


class GeometricTaskWorld(ABC):
    """A family's world in the geometric backend: bookkeeping without dynamics."""

    #: The object in the gripper, if any.
    held: str | None

    @abstractmethod
    def execute(self, command: RobotCommand, count_step: Callable[[], None]) -> None:
        """Carry out ``command``; call ``count_step`` for what counts against the step budget
        (before a refusal that still costs a step). Raises ``SkillError`` naming a refusal."""

    @abstractmethod
    def scene(self, episode_id: str, stamp: float, sequence: int, ended: bool) -> Scene:
        """What the world looks like now."""

    @abstractmethod
    def evaluate(self) -> Evaluation:
        """The family's success check on this world now."""


class PhysicsTaskWorld(ABC):
    """A family's reading of the physics world: ``physics`` is the simulator (arm, bodies),
    read back by the family's rules (scene and success) on the simulated poses."""

    physics: PhysicsWorld

    @abstractmethod
    def scene(
        self, episode_id: str, stamp: float, sequence: int, ended: bool, held: str | None
    ) -> Scene:
        """What the simulated world looks like now (``held``: the body between the fingers)."""

    @abstractmethod
    def evaluate(self, held: str | None) -> Evaluation:
        """The family's success check on the simulated poses now."""


#: Builds the physics backend's simulator with these bodies on its table (its config,
#: renderer, markers and the layout's containers are the backend's business).
MakePhysicsWorld = Callable[[list[Body]], "PhysicsWorld"]


class SimFamily(ABC):
    """A registered task family (``FAMILIES``); subclasses document their world and rule.

    Class attributes: ``layout_type`` (the layout its tasks make), ``tasks`` (their names in
    ``TASKS``), ``takes_task_files`` (whether a user's task file is laid out in its world),
    ``request_fields`` (the generic ``EpisodeRequest`` fields it reads into its options;
    the request's ``options`` are its own, by name)."""

    name: ClassVar[str]
    help: ClassVar[str] = ""
    options_type: ClassVar[type[Any]]
    layout_type: ClassVar[type[Layout]] = Layout
    tasks: ClassVar[tuple[str, ...]] = ()
    takes_task_files: ClassVar[bool] = False
    request_fields: ClassVar[tuple[str, ...]] = ()

    def options(self, request: EpisodeRequest, geometry: str = "geometric") -> Any:
        """This family's options for ``request``, its tasks laid out in ``geometry``'s world.
        A field of another family set in the request is refused (``ConfigError`` naming
        ``family.<field>``)."""
        if request.family is not None and request.family != self.name:
            raise ConfigError(
                "family", f"'{request.task}' is a task of {self.name}, not of {request.family}"
            )
        values = {name: getattr(request, name) for name in self.request_fields}
        for name in OWNED_FIELDS:
            if name not in values and getattr(request, name) is not None:
                values[name] = getattr(request, name)  # another family's: refused below
        for name, value in request.options.items():
            if name in _REQUEST_FIELDS:
                raise ConfigError(f"options.{name}", "is a field of the request, not an option")
            values[name] = value  # a name no family owns, or another family's: refused below
        return FAMILIES.options(self.name, values | self.geometry_options(geometry))

    def geometry_options(self, geometry: str) -> dict[str, Any]:
        """Options that lay this family's tasks out in ``geometry``'s world (none by default)."""
        if geometry not in GEOMETRIES:
            raise ConfigError("geometry", f"'{geometry}' is not one of: {', '.join(GEOMETRIES)}")
        return {}

    def task(self, request: EpisodeRequest, geometry: str = "geometric") -> Task[Any]:
        """The request's task with this family's options (``TaskError`` naming a bad one)."""
        if request.task == "file" or request.task_file is not None:
            return self.file_task(request)
        if request.rules is not None:
            raise ConfigError("rules", "rules are for a task file's goals; give its text too")
        return TASKS[request.task](self.options(request, geometry))

    def file_task(self, request: EpisodeRequest) -> Task[Any]:
        """The user's task file of ``request`` (families that take task files override)."""
        raise ConfigError("task_file", f"the {self.name} family takes no task files")

    def check_task_file(
        self, text: str, source: str, rules: str | None = None, rules_source: str = ""
    ) -> int:
        """Read and check a task file's ``text`` (and a rules file's, against it), where a
        command takes them, before any episode; returns how many objects it lays out.
        ``TaskError`` naming ``source``, the line and the field (families that take task
        files override)."""
        raise ConfigError("task_file", f"the {self.name} family takes no task files")

    def required_goals(self, layout: Any) -> set[str]:
        """The ids of the goals :meth:`evaluate` counts (``Layout.required_goals``)."""
        return layout.required_goals()

    def max_steps(self, task: Task[Any], layout: Any) -> int:
        """The episode's step budget when the request gives none."""
        return task.max_steps(len(layout.goals))

    @abstractmethod
    def evaluate(self, layout: Any, world: Any) -> Evaluation:
        """Whether ``world`` (this family's geometric world, or its view of the simulated
        poses) fills the goals of ``layout`` as the family's rule asks."""

    @abstractmethod
    def geometric_world(self, layout: Any, goal_tolerance: float) -> GeometricTaskWorld:
        """``layout`` as a world for the geometric backend."""

    def physics_world(
        self, layout: Any, make_world: MakePhysicsWorld, goal_tolerance: float
    ) -> PhysicsTaskWorld:
        """``layout`` in the physics backend's simulator (``make_world`` builds it). A family
        without one need not say so: the physics backend refuses its episodes, naming it."""
        raise ConfigError("backend", f"the {self.name} family has no physics world")


def _register_installed() -> None:
    """Register the ``sim`` part of every installed family package, by family name."""
    register_parts("sim", SimFamily, register_family)


#: Task families by name, each with its options (built from the episode request); the
#: installed family packages' are registered when it is first read.
FAMILIES: Registry[SimFamily] = Registry("family", fill=_register_installed)


def _register_tasks() -> None:
    """The families register their tasks as they are registered."""
    FAMILIES.names()


TASKS.fill_with(_register_tasks)

#: The request fields a family may own that are unset (None) unless a client chose them: one
#: set for a family that does not read it is refused. ``blocks`` and ``stacks`` have defaults
#: in the contract, so every request carries them; a family that does not read them ignores
#: them (it cannot tell a default from a choice). What else a family reads it owns: the
#: request's ``options``.
OWNED_FIELDS = ("objects",)
#: The request's own fields, which no family option may shadow.
_REQUEST_FIELDS = frozenset({"blocks", "stacks", "objects", "seed", "max_steps", "task"})


def register_family(family: type[SimFamily]) -> type[SimFamily]:
    """Register ``family`` (one instance) under its ``name`` with its ``options_type``."""
    FAMILIES.add(family.name, family(), options=family.options_type, help=family.help)
    return family


def family_of(request: EpisodeRequest) -> SimFamily:
    """The family whose task ``request`` asks for (a task file: the family that takes task
    files); ``ConfigError`` naming the known tasks if none has it."""
    wants_file = request.task == "file" or request.task_file is not None
    if request.family is not None and request.family not in FAMILIES.names():
        FAMILIES.check(request.family)  # an unknown family: ConfigError naming the known ones
    for _, family in FAMILIES.items():
        if (wants_file and family.takes_task_files) or request.task in family.tasks:
            return family
    TASKS.check(request.task)  # an unknown task: ConfigError naming the registered ones
    raise ConfigError("task", f"'{request.task}' belongs to no task family")


def task_file_family() -> SimFamily:
    """The family a user's task file is laid out by (``ConfigError`` if none takes them)."""
    for _, family in FAMILIES.items():
        if family.takes_task_files:
            return family
    raise ConfigError("task_file", "no installed task family takes task files")
