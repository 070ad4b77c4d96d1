"""The newest Scene, updated from the Zenoh thread, waitable from the service thread."""

from __future__ import annotations

import threading
from collections.abc import Callable

from manigraph_shared.messages import Scene


class SceneCache:
    def __init__(self) -> None:
        self._scene: Scene | None = None
        self._changed = threading.Condition()

    def update(self, scene: Scene) -> None:
        with self._changed:
            current = self._scene
            if (
                current is not None
                and current.episode_id == scene.episode_id
                and current.sequence > scene.sequence
            ):
                return  # an older sample overtaken on the way
            self._scene = scene
            self._changed.notify_all()

    def newest_sequence(self, episode_id: str) -> int | None:
        """Sequence of the cached scene if it is of ``episode_id``, else None."""
        scene = self._scene
        return scene.sequence if scene is not None and scene.episode_id == episode_id else None

    def wake(self) -> None:
        """Have every :meth:`wait_for` look at its ``give_up`` again (something changed)."""
        with self._changed:
            self._changed.notify_all()

    def wait_for(
        self,
        episode_id: str,
        sequence: int,
        timeout: float,
        give_up: Callable[[], bool] | None = None,
    ) -> Scene | None:
        """The newest scene of ``episode_id`` at least as new as ``sequence``, or the newest
        scene at all once ``timeout`` passes or ``give_up()`` is true (checked at each
        scene and each :meth:`wake`); the skill then reports what it sees."""

        def fresh() -> bool:
            scene = self._scene
            if scene is not None and scene.episode_id == episode_id and scene.sequence >= sequence:
                return True
            return give_up is not None and give_up()

        with self._changed:
            self._changed.wait_for(fresh, timeout)
            return self._scene
