"""Where a Panda motion driver's joint trajectories go: the :class:`JointTransport` shape (the
sim over the bus, a real arm, a backend in-process) and how a transport that caches streamed
scenes answers where an object is."""

from __future__ import annotations

import threading
from collections.abc import Callable
from typing import Protocol

import numpy as np

from manigraph_shared.messages import (
    JointTrajectoryCommand,
    JointTrajectoryResult,
    Scene,
    SceneFixture,
    SceneObject,
)


class JointTransport(Protocol):
    """Where joint trajectories go: the sim over the bus, a real arm, or a backend in-process."""

    def execute(self, command: JointTrajectoryCommand) -> JointTrajectoryResult:
        """Run ``command`` to the end and answer it."""
        ...

    def joint_positions(self) -> np.ndarray:
        """The arm's current joint positions, radians."""
        ...

    def object_position(self, object_id: str, after: float) -> np.ndarray | None:
        """Where ``object_id`` is, observed after time ``after``; None if unknown."""
        ...

    def stop(self) -> None:
        """Emergency stop: make a running ``execute`` return or raise at once."""
        ...

    def resume(self) -> None:
        """Accept trajectories again."""
        ...

    def abort(self, reason: str) -> None:
        """The robot went away: make a running ``execute`` raise ``SkillError(reason)``."""
        ...


def object_seen_after(
    lock: threading.Condition,
    latest_scene: Callable[[], Scene | None],
    object_id: str,
    after: float,
    timeout: float = 1.0,
) -> np.ndarray | None:
    """Where ``object_id`` (an object, or a rack: its handle) is in the newest scene stamped at
    or after ``after`` (waiting up to ``timeout`` for one on ``lock``, which the scene's writer
    notifies); None if none came or it is not in it. Shared by the transports that cache
    streamed scenes."""
    with lock:
        lock.wait_for(
            lambda: (scene := latest_scene()) is not None and scene.stamp >= after, timeout
        )
        scene = latest_scene()
    if scene is None or scene.stamp < after:
        return None
    return position_in(scene, object_id)


def position_in(scene: Scene, object_id: str) -> np.ndarray | None:
    """Where object ``object_id`` is in ``scene``, or fixture ``object_id``'s handle; None if
    neither is in it."""
    things: list[SceneObject | SceneFixture] = [*scene.objects, *scene.fixtures]
    for thing in things:
        if thing.id == object_id:
            return np.array(thing.position.as_tuple())
    return None
