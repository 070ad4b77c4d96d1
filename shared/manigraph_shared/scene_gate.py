"""Which scenes a service may act on: those of the running episode that move forward sanely.

A ``Scene`` that validates may still be forged or stale. Skills caches the newest scene and a
planner decides on it, so one scene with a huge sequence number, a stamp far in the future or
another episode's id would be acted on (or would shadow every real scene after it). The gate
refuses, with a named reason:

* ``stamp_in_future``: stamped more than ``max_future`` seconds ahead of this machine's clock;
* ``not_running_episode``: not the episode the world announced last (``EpisodeEvent`` start),
  while that episode is still running. Between episodes (the last one ended) the first scene
  of the next episode is accepted even if it overtook its start event;
* ``sequence_jump``: more than ``max_sequence_jump`` ahead of the newest accepted scene of the
  episode (the sim numbers scenes one by one);
* ``stamp_jump``: stamped more than ``max_stamp_jump`` seconds after the newest accepted one.

A scene refused as ``not_running_episode`` may only have overtaken the events that make it
acceptable (they come by another key, so by another path: the end of the running episode, its
own start). The gate keeps the newest such scene of the last few episodes and hands it back
from :meth:`SceneGate.on_episode` once those events arrive, for the caller to check again: a
planner that saw the next episode's first scene before its start event decides on it then,
instead of waiting for a scene that may never come.

Until the first start event (a service started mid-episode) the gate follows the scenes'
episode, since it has nothing better to go by. Replayed logs carry their own episode events
and old stamps, which the gate accepts: it never compares a stamp with the clock except to
refuse the future.
"""

from __future__ import annotations

import threading
import time
from collections import OrderedDict
from collections.abc import Callable
from dataclasses import dataclass

from manigraph_shared.errors import ConfigError
from manigraph_shared.messages import EpisodeEvent, EpisodePhase, Scene

#: Episodes whose overtaking scenes are kept (a forger's ids cannot grow it).
OVERTAKING_KEPT = 2


@dataclass(frozen=True)
class SceneLimits:
    """How far a scene may move ahead of the last accepted one."""

    max_sequence_jump: int = 1000
    max_stamp_jump: float = 60.0
    max_future: float = 60.0

    def __post_init__(self) -> None:
        if self.max_sequence_jump < 1:
            raise ConfigError("max_sequence_jump", "must be >= 1")
        for name in ("max_stamp_jump", "max_future"):
            if not getattr(self, name) > 0:
                raise ConfigError(name, "must be > 0 seconds")


class SceneGate:
    """Thread-safe: episode events and scenes may come from different Zenoh threads."""

    def __init__(
        self, limits: SceneLimits | None = None, clock: Callable[[], float] = time.time
    ) -> None:
        self.limits = limits or SceneLimits()
        self.clock = clock
        self.running: str | None = None
        self._announced = False  # running comes from a start event, not from a scene
        self._ended = False
        self._newest: tuple[int, float] | None = None  # (sequence, stamp) accepted last
        self._overtaking: OrderedDict[str, Scene] = OrderedDict()  # episode -> newest refused
        self._lock = threading.Lock()

    def on_episode(self, event: EpisodeEvent) -> list[Scene]:
        """Follow the world's episodes; returns the refused scenes that ``event`` may make
        acceptable (they overtook it), oldest first, for the caller to :meth:`check` again."""
        with self._lock:
            if event.phase is EpisodePhase.START:
                if event.episode_id != self.running:
                    self._newest = None
                self.running, self._announced, self._ended = event.episode_id, True, False
                scene = self._overtaking.pop(event.episode_id, None)
                return [scene] if scene is not None else []
            if event.episode_id == self.running:
                self._ended = True
                overtaking = list(self._overtaking.values())
                self._overtaking.clear()
                return overtaking
            return []

    def is_running(self, episode_id: str) -> bool:
        """Whether ``episode_id`` may be acted on (True while no episode is known)."""
        with self._lock:
            return self.running is None or self.running == episode_id

    def has_ended(self, episode_id: str) -> bool:
        """Whether ``episode_id`` is the episode the world announced last and it has ended
        (no start event of another since)."""
        with self._lock:
            return self.running == episode_id and self._ended

    def may_be_next(self, episode_id: str) -> bool:
        """Whether ``episode_id`` is running or may be the one to start next (the running one
        has ended): a message of the next episode may overtake its start event, coming from
        another process by another path."""
        with self._lock:
            return self.running is None or self.running == episode_id or self._ended

    def check(self, scene: Scene) -> str | None:
        """None if ``scene`` is acceptable (and remember it), else the reason to refuse it."""
        limits = self.limits
        with self._lock:
            if scene.stamp > self.clock() + limits.max_future:
                return "stamp_in_future"
            if scene.episode_id != self.running:
                if self._announced and not self._ended:
                    self._keep_overtaking(scene)
                    return "not_running_episode"
                self.running, self._ended, self._newest = scene.episode_id, False, None
            if self._newest is not None:
                sequence, stamp = self._newest
                if scene.sequence > sequence + limits.max_sequence_jump:
                    return "sequence_jump"
                if scene.stamp > stamp + limits.max_stamp_jump:
                    return "stamp_jump"
            if self._newest is None or scene.sequence > self._newest[0]:
                self._newest = (scene.sequence, scene.stamp)
            if scene.episode_ended:
                self._ended = True
            return None

    def _keep_overtaking(self, scene: Scene) -> None:
        kept = self._overtaking.get(scene.episode_id)
        if kept is not None and kept.sequence >= scene.sequence:
            return
        self._overtaking[scene.episode_id] = scene
        self._overtaking.move_to_end(scene.episode_id)
        while len(self._overtaking) > OVERTAKING_KEPT:
            self._overtaking.popitem(last=False)
