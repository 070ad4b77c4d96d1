"""Episode life cycle: the request that starts one and the events it emits."""

from __future__ import annotations

from enum import StrEnum
from typing import ClassVar, Self

from pydantic import Field, model_validator

from manigraph_shared.messages.base import Delivery, Identifier, Message, Stamp


class EpisodeRequest(Message):
    """Ask the world to reset into a new seeded episode (query payload)."""

    key: ClassVar[str] = "manigraph/world/reset"
    delivery: ClassVar[Delivery] = Delivery.QUERY
    publisher: ClassVar[str] = "run client -> sim"

    episode_id: Identifier
    task: str = Field(max_length=64, description="registered task name, e.g. stack")
    blocks: int = Field(4, ge=1, le=64, description="blocks per stack (K)")
    stacks: int = Field(1, ge=1, le=16, description="number of stacks (s)")
    objects: int | None = Field(
        None, ge=1, le=64, description="dishes (dishwasher task): half plates, half bowls"
    )
    preference: str | None = Field(
        None, max_length=64, description="how to load (dishwasher task): top-bottom, left-right"
    )
    seed: int = Field(0, ge=0, le=2**32 - 1)
    max_steps: int | None = Field(None, ge=1, le=10_000, description="default: 2 x goals + 4")
    task_file: str | None = Field(
        None, max_length=65_536, description="TOML text of a user layout (with task 'file')"
    )


class EpisodePhase(StrEnum):
    START = "start"
    END = "end"


class EpisodeEvent(Message):
    """An episode started or ended."""

    key: ClassVar[str] = "manigraph/world/episode"
    delivery: ClassVar[Delivery] = Delivery.RELIABLE
    publisher: ClassVar[str] = "sim"

    episode_id: Identifier
    phase: EpisodePhase
    task: str = Field(max_length=64)
    seed: int = Field(ge=0)
    goals_total: int = Field(ge=0)
    goals_filled: int = Field(ge=0)
    steps: int = Field(0, ge=0, description="skills executed so far")
    success: bool | None = Field(None, description="all goals filled; set at end")
    reason: str = Field("", max_length=256, description="why it ended")
    sim_seconds: float | None = Field(
        None,
        ge=0,
        le=1e6,
        description="simulated seconds the episode took, set at end by a world with a clock "
        "(physics); compare with wall time to see the real-time factor",
    )
    stamp: Stamp

    @model_validator(mode="after")
    def _consistent(self) -> Self:
        if self.goals_filled > self.goals_total:
            raise ValueError("goals_filled: more than goals_total")
        if self.phase is EpisodePhase.END and self.success is None:
            raise ValueError("success: required when phase is end")
        return self
