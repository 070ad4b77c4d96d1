"""Helpers for the reliability tests: real processes on loopback, a client that can forge."""

from __future__ import annotations

import queue
import threading
import time
from collections.abc import Callable
from typing import TypeVar

from manigraph_shared.bus import Bus
from manigraph_shared.messages import (
    Action,
    EpisodeEvent,
    EpisodeRequest,
    Message,
    Scene,
    ServiceStatus,
)
from manigraph_testkit.testing import Stack

M = TypeVar("M", bound=Message)


def start(stack: Stack, *services: str, **extra: list[str]) -> None:
    """The router and ``services`` (each ``manigraph <name>``, plus ``extra[name]`` args)."""
    stack.start("router")
    for name in services:
        stack.start(name, name, *extra.get(name, []))


class Inbox:
    """Every valid message of one type, as it arrives."""

    def __init__(self, bus: Bus, message_type: type[M], key: str | None = None) -> None:
        self.items: queue.SimpleQueue[Message] = queue.SimpleQueue()
        self.seen: list[Message] = []
        self._lock = threading.Lock()
        bus.subscribe(message_type, self._put, key=key)

    def _put(self, message: Message) -> None:
        with self._lock:
            self.seen.append(message)
        self.items.put(message)

    def wait(self, match: Callable[[M], bool], timeout: float = 10.0) -> M:
        deadline = time.monotonic() + timeout
        while True:
            remaining = deadline - time.monotonic()
            if remaining <= 0:
                raise AssertionError(f"nothing matching within {timeout} s")
            try:
                item = self.items.get(timeout=remaining)
            except queue.Empty:
                continue
            if match(item):  # type: ignore[arg-type]
                return item  # type: ignore[return-value]


def reset(bus: Bus, episode_id: str, blocks: int = 4, seed: int = 0) -> EpisodeEvent:
    return bus.request(
        EpisodeRequest(episode_id=episode_id, task="stack", blocks=blocks, seed=seed),
        EpisodeEvent,
        timeout=20.0,
    )


def scene_of(scenes: Inbox, episode_id: str, timeout: float = 10.0) -> Scene:
    return scenes.wait(lambda s: s.episode_id == episode_id, timeout)


def rejections(statuses: Inbox, service: str, kind: str, timeout: float = 5.0) -> int:
    """The count of ``kind`` refusals ``service`` reports (waits for a heartbeat that has it)."""
    status: ServiceStatus = statuses.wait(
        lambda s: s.service == service and s.rejections.get(kind, 0) > 0, timeout
    )
    return status.rejections[kind]


def action(
    scene: Scene, object_id: str, goal_id: str, decision_id: str, **changes: object
) -> Action:
    """A well-formed Action on ``scene`` (what a forger, or the test's planner, sends)."""
    fields: dict[str, object] = {
        "decision_id": decision_id,
        "episode_id": scene.episode_id,
        "scene_sequence": scene.sequence,
        "object_id": object_id,
        "goal_id": goal_id,
        "policy": "test",
        "stamp": time.time(),
        **changes,
    }
    return Action.from_builtins(fields)


def top_block_and_free_goal(scene: Scene) -> tuple[str, str]:
    """The top block of the source stack and the lowest free goal (a legal first move)."""
    block = max((o for o in scene.objects if not o.filled), key=lambda o: o.position.z)
    goal = min((g for g in scene.goals if not g.filled), key=lambda g: g.position.z)
    return block.id, goal.id


#: Seconds a service may take to start: the planner imports torch, which takes 40 s on a
#: 2-core machine shared with other jobs.
STARTUP = 120.0
