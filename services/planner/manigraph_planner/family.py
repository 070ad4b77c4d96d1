"""A task family's part of the planner, as one registered unit (docs/architecture.md).

A family owns what the planner does differently for its scenes: which scenes are its
(:attr:`PlannerFamily.matches`), the network heads its policies are trained with and the
feature spec of their graph states, the network and policy a checkpoint with those heads
loads as, its experts (and which one demonstrates an episode), the augmentation recipes the
generic trainer draws with for its heads, or its own ``manigraph train``. Its package
(``families/<name>/``, docs/families.md) holds that code in its ``planner`` part, which
names its :class:`PlannerFamily` in the package's ``manigraph.families`` entry point
(:mod:`manigraph_shared.family_packages`); :data:`FAMILIES` registers every installed one,
by name, when it is first read. The generic layers (``gnn/``, ``policies/``, ``explain/``, and
the training package, ``manigraph_training``) ask the registry, never which family a scene is:

    family_of(scene).heads                 # what a decision on this scene trains
    family_for_heads(config.heads).network # what a checkpoint with these heads builds

The heavy parts (networks, policies, training, anything importing torch) are named as
``"module:attribute"`` and imported when first used (:meth:`PlannerFamily.part`), so
registering a family and listing the policies stays torch-free. ``recipe`` and
``train_command`` name the family's training part (``manigraph_<name>.training``), which only
the training package imports: the serving planner never loads it.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

from manigraph_shared.errors import ConfigError
from manigraph_shared.family_packages import check_one_fallback, family_of_scene, register_parts
from manigraph_shared.messages import EpisodeRequest, Scene
from manigraph_shared.registry import Registry, import_target

if TYPE_CHECKING:
    from manigraph_planner.policies.base import Policy

__all__ = ["FAMILIES", "PlannerFamily", "family_for_heads", "family_of", "register_family"]


def _any_scene(scene: Scene) -> bool:
    return True


@dataclass(frozen=True)
class PlannerFamily:
    """One task family's planner parts.

    Args:
        name: the family (its entry point's name), as in the sim's and skills' registries.
        heads: the network heads its learned policies have (``ModelConfig.heads``, a
            :data:`~manigraph_planner.gnn.models.config.HEADS` entry).
        experts: the policy names of its experts (registered in ``POLICIES`` by its expert
            module, which its part imports); :meth:`expert` picks the one that demonstrates
            an episode (``manigraph demos``).
        expert_of: which of ``experts`` demonstrates an episode request (e.g. by an option
            of the request); None: the first.
        matches: whether a scene is this family's (what the scene itself shows).
        fallback: the family of every scene no other family matches (one family: blocks, whose
            object-goal heads are the paper's and any task file's).
        feature_spec: ``"module:attribute"`` of its heads' feature spec; None: the paper's
            (already registered under ``object-goal``).
        network: ``"module:attribute"`` of ``(ModelConfig, message_passing) -> PolicyNet``
            for its heads; None: the paper's :class:`PolicyNet`.
        policy: ``"module:attribute"`` of ``(net, CheckpointInfo) -> Policy`` for a loaded
            checkpoint; None: :class:`~manigraph_planner.policies.gnn.GNNPolicy`.
        recipe: ``"module:attribute"`` of the :class:`~manigraph_shared.registry.Registry`
            of augmentation recipes by architecture that the generic trainer draws with for
            its heads (``manigraph_training.recipes``); None for a family with its own
            ``train_command``.
        train_command: ``"module:attribute"`` of ``(args) -> exit code``: what ``manigraph
            train`` runs for demonstrations of this family; None: the generic command.
        ensembles: whether its networks may be ensembles (``ModelConfig.ensemble`` > 1).
    """

    name: str
    heads: str
    experts: tuple[str, ...]
    expert_of: Callable[[EpisodeRequest], str] | None = None
    matches: Callable[[Scene], bool] = _any_scene
    fallback: bool = False
    feature_spec: str | None = None
    network: str | None = None
    policy: str | None = None
    recipe: str | None = None
    train_command: str | None = None
    ensembles: bool = False
    help: str = ""

    def part(self, name: str) -> Any:
        """The part ``name`` (``network``, ``policy``, ``recipe``, ...) imported, or None."""
        path = getattr(self, name)
        return None if path is None else import_target(path)

    def expert(self, request: EpisodeRequest) -> Policy:
        """A fresh expert that demonstrates ``request``: the one :attr:`expert_of` names, else
        the first of :attr:`experts`."""
        from manigraph_planner.policies.base import POLICIES  # it imports the families

        name = self.experts[0] if self.expert_of is None else self.expert_of(request)
        if name not in self.experts:
            raise ConfigError("expert", f"'{name}' is not one of the {self.name} experts")
        return POLICIES[name]()


def _register_installed() -> None:
    """Register the ``planner`` part of every installed family package, by family name."""
    register_parts("planner", PlannerFamily, register_family)


#: Every task family the planner knows, by name: the installed family packages' are
#: registered when it is first read.
FAMILIES: Registry[PlannerFamily] = Registry("family", fill=_register_installed)


def register_family(family: PlannerFamily) -> PlannerFamily:
    """Add ``family`` to :data:`FAMILIES`; a second fallback family is refused."""
    check_one_fallback(family, (known for _, known in FAMILIES.items()))
    FAMILIES.add(family.name, family, help=family.help)
    return family


def family_of(scene: Scene) -> PlannerFamily:
    """The family ``scene`` belongs to: the first that matches it, else the fallback."""
    return family_of_scene((family for _, family in FAMILIES.items()), scene)


def family_for_heads(heads: str) -> PlannerFamily:
    """The family whose policies have ``heads`` (``ConfigError`` naming the known heads)."""
    for _, family in FAMILIES.items():
        if family.heads == heads:
            return family
    known = ", ".join(family.heads for _, family in FAMILIES.items())
    raise ConfigError("heads", f"'{heads}' is not one of {known}")
