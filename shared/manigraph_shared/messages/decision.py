"""What the planner decided and what became of it."""

from __future__ import annotations

from enum import StrEnum
from typing import Annotated, Any, ClassVar, Literal

from msgspec import Meta

from manigraph_shared.messages import legacy
from manigraph_shared.messages.base import Delivery, FamilyName, Identifier, Message, Stamp

#: Why a policy's first choice was passed over (``Action.recovery``).
RecoveryReason = Literal["no_progress", "repeated_pair", "escalated", "exhausted", "refused"]


class Action(Message, frozen=True, kw_only=True):
    """Move ``object_id`` to ``goal_id`` (PickAndPlace), or operate a fixture.

    A placement turns the object to ``orientation_index`` (``manigraph_shared.orientations``)
    when set; a family action (``family_action``, a name the task's family defines, such as
    ``toggle``) names its fixture (``Scene.fixtures``) as object and goal."""

    key: ClassVar[str] = "manigraph/planner/action"
    delivery: ClassVar[Delivery] = Delivery.RELIABLE
    publisher: ClassVar[str] = "planner (or demo-ui while a person teaches)"

    decision_id: Annotated[Identifier, Meta(description="`<episode>:<step>`, unique per decision")]
    episode_id: Identifier
    scene_sequence: Annotated[
        int, Meta(ge=0, description="sequence of the Scene this decision used")
    ]
    object_id: Identifier
    goal_id: Identifier
    orientation_index: Annotated[
        Annotated[int, Meta(ge=0, le=5)] | None,
        Meta(description="one of six discrete orientations (orientations.py)"),
    ] = None
    family_action: Annotated[
        FamilyName | None,
        Meta(
            description="an action the task's family defines (e.g. toggle) on the fixture "
            "named as object and goal; null: pick and place"
        ),
    ] = None
    policy: Annotated[str, Meta(max_length=128, description="name of the policy that decided")]
    stamp: Stamp
    rank: Annotated[
        int,
        Meta(ge=0, description="0: the policy's first choice; k: its k-th alternative (recovery)"),
    ] = 0
    recovery: Annotated[
        RecoveryReason | None,
        Meta(
            description="why the first choice was passed over: the world did not change after it, "
            "it repeated a pair with no goal filled since, its object or goal failed twice; "
            "exhausted: every alternative failed, the first choice again (or the best one "
            "not refused); refused: the skills refused it and nothing near it moved since"
        ),
    ] = None
    passed_over: Annotated[
        Annotated[str, Meta(max_length=256)] | None,
        Meta(
            description="the refusal this decision passes over, `object->goal: reason` "
            "(docs/recovery.md)"
        ),
    ] = None

    def _check(self) -> None:
        if self.family_action is not None and self.object_id != self.goal_id:
            raise ValueError("goal_id: a family action names its fixture as object and goal")

    @classmethod
    def upgrade(cls, data: dict[str, Any]) -> dict[str, Any]:
        """An action of contract version 1-3 in this version's fields (:mod:`.legacy`)."""
        return legacy.action(data)


#: Failure reasons of a skill that refused its action before any motion, because the action
#: itself could not be acted on (an object or goal the scene does not have, another episode, a
#: full queue, an emergency stop). Such a failure is not a step of the episode: counting it
#: would let forged actions spend an episode's step budget.
REFUSAL_REASONS = frozenset(
    {
        "unknown_object",
        "unknown_goal",
        "not_running_episode",
        "unknown_scene",
        "skills_busy",
        "stopped",
    }
)


class SkillState(StrEnum):
    ACCEPTED = "accepted"
    RUNNING = "running"
    SUCCEEDED = "succeeded"
    FAILED = "failed"

    @property
    def terminal(self) -> bool:
        return self in (SkillState.SUCCEEDED, SkillState.FAILED)


class SkillStatus(Message, frozen=True, kw_only=True):
    """Progress of the skill executing one decision."""

    key: ClassVar[str] = "manigraph/skills/status"
    delivery: ClassVar[Delivery] = Delivery.RELIABLE
    publisher: ClassVar[str] = "skills"

    decision_id: Identifier
    skill: Annotated[str, Meta(max_length=64, description="e.g. pick_and_place")]
    state: SkillState
    reason: Annotated[
        Annotated[str, Meta(max_length=64)] | None,
        Meta(description="machine-readable cause, required when failed"),
    ] = None
    detail: Annotated[str, Meta(max_length=1024)] = ""
    stamp: Stamp

    def _check(self) -> None:
        if self.state is SkillState.FAILED and not self.reason:
            raise ValueError("reason: a failed status must say why")
