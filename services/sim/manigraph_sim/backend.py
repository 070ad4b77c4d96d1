"""What a sim backend offers the sim service; backends are registered by name."""

from __future__ import annotations

from abc import ABC, abstractmethod
from collections.abc import Callable

from manigraph_shared.errors import ConfigError
from manigraph_shared.messages import (
    EpisodeEvent,
    EpisodeRequest,
    RobotCommand,
    RobotFeedback,
    Scene,
)


class SimBackend(ABC):
    """A world that can be reset into a seeded episode, observed and commanded.

    All methods take and return contract messages, so the logic is testable without a bus.
    """

    @abstractmethod
    def reset(self, request: EpisodeRequest, stamp: float) -> EpisodeEvent:
        """Lay out a new episode; returns its start event."""

    @abstractmethod
    def scene(self, stamp: float) -> Scene | None:
        """The current observation, or None before the first episode."""

    @abstractmethod
    def execute(self, command: RobotCommand, stamp: float) -> RobotFeedback:
        """Carry out one robot command."""

    @abstractmethod
    def end_event(self, stamp: float) -> EpisodeEvent | None:
        """The end event, once, when the episode has just ended; else None."""


BACKENDS: dict[str, Callable[..., SimBackend]] = {}


def register_backend(name: str) -> Callable[[Callable[..., SimBackend]], Callable[..., SimBackend]]:
    def register(factory: Callable[..., SimBackend]) -> Callable[..., SimBackend]:
        BACKENDS[name] = factory
        return factory

    return register


def create_backend(name: str, **options: object) -> SimBackend:
    if name not in BACKENDS:
        raise ConfigError("backend", f"'{name}' is not one of {', '.join(sorted(BACKENDS))}")
    return BACKENDS[name](**options)
