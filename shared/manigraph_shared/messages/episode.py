"""Episode life cycle: the request that starts one and the events it emits."""

from __future__ import annotations

from enum import StrEnum
from typing import Annotated, Any, ClassVar

import msgspec
from msgspec import Meta

from manigraph_shared.messages import legacy
from manigraph_shared.messages.base import (
    MAX_ATTRIBUTES,
    AttributeName,
    Delivery,
    FamilyName,
    FamilyScalar,
    Identifier,
    Message,
    Stamp,
)


class EpisodeRequest(Message, frozen=True, kw_only=True):
    """Ask the world to reset into a new seeded episode (query payload)."""

    key: ClassVar[str] = "manigraph/world/reset"
    delivery: ClassVar[Delivery] = Delivery.QUERY
    publisher: ClassVar[str] = "run client -> sim"

    episode_id: Identifier
    task: Annotated[str, Meta(max_length=64, description="registered task name, e.g. stack")]
    blocks: Annotated[int, Meta(ge=1, le=64, description="blocks per stack (K)")] = 4
    stacks: Annotated[int, Meta(ge=1, le=16, description="number of stacks (s)")] = 1
    family: Annotated[
        FamilyName | None,
        Meta(description="the task's family (null: the family whose task it is)"),
    ] = None
    objects: Annotated[
        Annotated[int, Meta(ge=1, le=64)] | None,
        Meta(description="objects the task lays out, as its family says (null: its default)"),
    ] = None
    options: Annotated[
        dict[AttributeName, FamilyScalar],
        Meta(
            max_length=MAX_ATTRIBUTES,
            description="options the task's family owns, by name (docs/families.md); the "
            "family refuses a name it does not know",
        ),
    ] = msgspec.field(default_factory=dict)
    seed: Annotated[int, Meta(ge=0, le=2**32 - 1)] = 0
    max_steps: Annotated[
        Annotated[int, Meta(ge=1, le=10_000)] | None, Meta(description="default: 2 x goals + 4")
    ] = None
    task_file: Annotated[
        Annotated[str, Meta(max_length=65_536)] | None,
        Meta(description="TOML text of a user layout (with task 'file')"),
    ] = None
    rules: Annotated[
        Annotated[str, Meta(max_length=65_536)] | None,
        Meta(
            description="TOML text of rules only the judge knows (with task 'file'): the sim "
            "decides success, wrong objects and rule violations by them; never in a Scene or "
            "TaskLayout"
        ),
    ] = None

    @classmethod
    def upgrade(cls, data: dict[str, Any]) -> dict[str, Any]:
        """A request of contract version 1-3 in this version's fields (:mod:`.legacy`)."""
        return legacy.episode_request(data)


class EpisodePhase(StrEnum):
    START = "start"
    END = "end"


class EpisodeEvent(Message, frozen=True, kw_only=True):
    """An episode started or ended."""

    key: ClassVar[str] = "manigraph/world/episode"
    delivery: ClassVar[Delivery] = Delivery.RELIABLE
    publisher: ClassVar[str] = "sim"

    episode_id: Identifier
    phase: EpisodePhase
    task: Annotated[str, Meta(max_length=64)]
    seed: Annotated[int, Meta(ge=0)]
    goals_total: Annotated[int, Meta(ge=0)]
    goals_filled: Annotated[int, Meta(ge=0)]
    steps: Annotated[int, Meta(ge=0, description="skills executed so far")] = 0
    goals_wrong_object: Annotated[
        int,
        Meta(ge=0, description="goals holding an object their ``accepts`` does not admit"),
    ] = 0
    rule_violations: Annotated[
        int,
        Meta(
            ge=0,
            description="placements into a goal the request's rules do not accept, counted "
            "even when later undone (0 without rules)",
        ),
    ] = 0
    success: Annotated[bool | None, Meta(description="all goals filled; set at end")] = None
    reason: Annotated[str, Meta(max_length=256, description="why it ended")] = ""
    sim_seconds: Annotated[
        Annotated[float, Meta(ge=0, le=1e6)] | None,
        Meta(
            description="simulated seconds the episode took, set at end by a world with a clock "
            "(physics); compare with wall time to see the real-time factor"
        ),
    ] = None
    stamp: Stamp

    def _check(self) -> None:
        if self.goals_filled > self.goals_total:
            raise ValueError("goals_filled: more than goals_total")
        if self.phase is EpisodePhase.END and self.success is None:
            raise ValueError("success: required when phase is end")
