"""A policy maps a ``Scene`` to a decision: which object to which goal (and how)."""

from __future__ import annotations

from abc import ABC, abstractmethod
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

from manigraph_shared.errors import PolicyError
from manigraph_shared.ids import derived_id
from manigraph_shared.messages import Action, Scene, TrayAction


@dataclass(frozen=True)
class Decision:
    object_id: str
    goal_id: str
    orientation_index: int | None = None
    tray_action: TrayAction = TrayAction.NONE

    def to_action(self, scene: Scene, step: int, policy: str, stamp: float) -> Action:
        """The contract message for this decision, step ``step`` of the scene's episode; the id
        ``<episode>:<step>`` is what lets a recorded log drive a fresh planner to the same ids
        (an episode id too long for that is shortened with a hash: ``manigraph_shared.ids``)."""
        return Action(
            decision_id=derived_id(scene.episode_id, ":", str(step)),
            episode_id=scene.episode_id,
            scene_sequence=scene.sequence,
            object_id=self.object_id,
            goal_id=self.goal_id,
            orientation_index=self.orientation_index,
            tray_action=self.tray_action,
            policy=policy,
            stamp=stamp,
        )


class Policy(ABC):
    name: str

    @abstractmethod
    def decide(self, scene: Scene) -> Decision | None:
        """The next decision, or None when there is nothing left to do."""


POLICIES: dict[str, Callable[[], Policy]] = {}
#: Loaders for policy files, by suffix (``.pt`` checkpoints register themselves here).
POLICY_FILE_LOADERS: dict[str, Callable[[Path], Policy]] = {}


def register_policy(name: str) -> Callable[[type[Policy]], type[Policy]]:
    def register(cls: type[Policy]) -> type[Policy]:
        cls.name = name
        POLICIES[name] = cls
        return cls

    return register


def load_policy(spec: str) -> Policy:
    """A registered policy by name, or a policy file (checkpoint) by path."""
    if spec in POLICIES:
        return POLICIES[spec]()
    path = Path(spec)
    loader = POLICY_FILE_LOADERS.get(path.suffix)
    if loader is None:
        known = ", ".join(sorted(POLICIES))
        raise PolicyError(
            f"policy: '{spec}' is neither a registered policy ({known}) nor a checkpoint"
        )
    if not path.is_file():
        raise PolicyError(f"policy: no such checkpoint file: {path}")
    return loader(path)
