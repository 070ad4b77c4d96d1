"""A policy maps a ``Scene`` to a decision: which object to which goal (and how)."""

from __future__ import annotations

from abc import ABC, abstractmethod
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import cast

from manigraph_shared.errors import PolicyError
from manigraph_shared.ids import derived_id
from manigraph_shared.messages import Action, Scene
from manigraph_shared.messages.decision import RecoveryReason
from manigraph_shared.registry import Registry


@dataclass(frozen=True)
class Decision:
    object_id: str
    goal_id: str
    orientation_index: int | None = None
    #: An action the task's family defines on the fixture named as object and goal.
    family_action: str | None = None

    @property
    def pair(self) -> tuple[str, str]:
        return (self.object_id, self.goal_id)

    def to_action(
        self,
        scene: Scene,
        step: int,
        policy: str,
        stamp: float,
        rank: int = 0,
        recovery: str | None = None,
    ) -> Action:
        """The contract message for this decision, step ``step`` of the scene's episode; the id
        ``<episode>:<step>`` is what lets a recorded log drive a fresh planner to the same ids
        (an episode id too long for that is shortened with a hash: ``manigraph_shared.ids``).
        ``rank`` and ``recovery`` say that the policy's first choice was passed over, and why."""
        return Action(
            decision_id=derived_id(scene.episode_id, ":", str(step)),
            episode_id=scene.episode_id,
            scene_sequence=scene.sequence,
            object_id=self.object_id,
            goal_id=self.goal_id,
            orientation_index=self.orientation_index,
            family_action=self.family_action,
            policy=policy,
            stamp=stamp,
            rank=rank,
            recovery=cast("RecoveryReason | None", recovery),  # one of its names, by construction
        )


class Policy(ABC):
    name: str
    #: Passed-over pairs with one object before the planner's recovery passes over every
    #: pair with it (``recovery.ProgressMonitor``).
    object_escalation: int = 2
    #: Whether it takes only the pairs whose goal accepts the object, as the scene's own
    #: columns say (a learned task policy: on by default, ``--accepts-filter off`` turns it
    #: off to judge the network alone); None: the policy has no such filter.
    accepts_filter: bool | None = None

    @abstractmethod
    def decide(self, scene: Scene) -> Decision | None:
        """The next decision, or None when there is nothing left to do."""

    def ranked(self, scene: Scene) -> list[Decision]:
        """Every decision this policy would consider on ``scene``, most likely first; the first
        is :meth:`decide`'s. The planner takes a later one only when the first made no
        progress. A policy without alternatives returns its one decision."""
        decision = self.decide(scene)
        return [] if decision is None else [decision]


def _register_families() -> None:
    """Each family registers its experts as it is registered (``manigraph_planner.family``)."""
    from manigraph_planner.family import FAMILIES

    FAMILIES.names()


#: Policies by name; a policy takes no options (a learned one comes from its checkpoint).
#: The installed families' experts are registered when it is first read.
POLICIES: Registry[type[Policy]] = Registry("policy", fill=_register_families)
register_policy = POLICIES.register
#: Loaders of policy files, by suffix; ``.pt`` checkpoints load a GNN policy (torch is
#: imported only then).
POLICY_FILE_LOADERS: Registry[Callable[[Path], Policy]] = Registry("policy file")
POLICY_FILE_LOADERS.add_lazy(
    ".pt", "manigraph_planner.policies.gnn:load_gnn_policy", help="a GNN policy checkpoint"
)


#: ``--accepts-filter``'s values: on (the default) or off.
ACCEPTS_FILTER_CHOICES = ("on", "off")


def load_policy(spec: str, *, accepts_filter: str = "on") -> Policy:
    """A registered policy by name, or a policy file (checkpoint) by path; ``accepts_filter``
    ``"off"`` lets a learned task policy take pairs its goals do not accept (what the network
    alone chooses), and is refused for a policy without the filter."""
    if accepts_filter not in ACCEPTS_FILTER_CHOICES:
        raise PolicyError(f"accepts-filter: must be on or off, not {accepts_filter!r}")
    policy = _load(spec)
    if accepts_filter == "off":
        if policy.accepts_filter is None:
            raise PolicyError(
                f"accepts-filter: '{spec}' has no accepts filter to turn off (only a policy "
                "learned from a task file's demonstrations has one)"
            )
        policy.accepts_filter = False
    return policy


def _load(spec: str) -> Policy:
    if spec in POLICIES:
        return POLICIES[spec]()
    path = Path(spec)
    if path.suffix not in POLICY_FILE_LOADERS:
        known = ", ".join(POLICIES)
        files = ", ".join(POLICY_FILE_LOADERS)
        raise PolicyError(
            f"policy: '{spec}' is neither a registered policy ({known}) nor a policy file ({files})"
        )
    if not path.is_file():
        raise PolicyError(f"policy: no such checkpoint file: {path}")
    return POLICY_FILE_LOADERS[path.suffix](path)
