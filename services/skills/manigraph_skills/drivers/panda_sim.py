"""``panda-sim``: the Panda motion driver talking to the physics sim over the bus.

Joint trajectories go out on ``manigraph/robot/joint_trajectory``; the sim answers each with a
``JointTrajectoryResult``. Joint state and scenes are cached as they stream in. A hardware
Franka driver reuses :class:`PandaMotionDriver` with a transport to the real arm.
"""

from __future__ import annotations

import threading
from typing import Any

import numpy as np

from manigraph_shared.bus import Bus
from manigraph_shared.errors import SkillError
from manigraph_shared.messages import (
    EpisodeEvent,
    JointState,
    JointTrajectoryCommand,
    JointTrajectoryResult,
    Scene,
)
from manigraph_shared.scene_gate import SceneGate
from manigraph_skills.drivers.joint_transport import object_seen_after
from manigraph_skills.drivers.panda_motion import PandaMotionDriver


class BusJointTransport:
    """Publishes trajectories and waits for their results; caches joint state and scenes."""

    def __init__(self, bus: Bus, timeout: float = 60.0) -> None:
        self.bus = bus
        self.timeout = timeout
        self._lock = threading.Condition()
        self._results: dict[str, JointTrajectoryResult] = {}
        self._waiting: set[str] = set()
        self._positions: np.ndarray | None = None
        #: Stamp of the newest joint knowledge; a sample older than it is stale.
        self._known_at = -1.0
        self._scene: Scene | None = None
        self._stopped = False
        self._aborted: dict[str, str] = {}
        #: Scenes check placements, so a forged one must not land here either (the service
        #: counts the refusals: it sees the same scenes through its own gate).
        self._gate = SceneGate()
        bus.subscribe(JointTrajectoryResult, self._on_result)
        bus.subscribe(JointState, self._on_state)
        bus.subscribe(EpisodeEvent, self._on_episode)
        bus.subscribe(Scene, self._on_scene)

    def _on_result(self, result: JointTrajectoryResult) -> None:
        with self._lock:
            if result.command_id in self._waiting:
                self._results[result.command_id] = result
                self._lock.notify_all()
            if result.positions and result.stamp >= self._known_at:
                # An answer carries the joints the motion ended in; a JointState stamped
                # before the motion started (overtaken on the way) must not replace them.
                self._positions, self._known_at = np.array(result.positions), result.stamp

    def _on_state(self, state: JointState) -> None:
        with self._lock:
            if state.stamp >= self._known_at:
                self._positions, self._known_at = np.array(state.positions), state.stamp
                self._lock.notify_all()

    def _on_episode(self, event: EpisodeEvent) -> None:
        for scene in self._gate.on_episode(event):  # overtook the event; acceptable now
            self._on_scene(scene)

    def _on_scene(self, scene: Scene) -> None:
        if self._gate.check(scene) is not None:
            return
        with self._lock:
            self._scene = scene
            self._lock.notify_all()

    def stop(self) -> None:
        with self._lock:
            self._stopped = True
            self._lock.notify_all()

    def resume(self) -> None:
        with self._lock:
            self._stopped = False

    def abort(self, reason: str) -> None:
        with self._lock:
            for command_id in self._waiting:
                self._aborted[command_id] = reason
            self._lock.notify_all()

    def execute(self, command: JointTrajectoryCommand) -> JointTrajectoryResult:
        with self._lock:
            if self._stopped:
                raise SkillError("stopped", "emergency stop engaged")
            self._waiting.add(command.command_id)
        try:
            self.bus.publish(command)
            with self._lock:
                if not self._lock.wait_for(
                    lambda: (
                        command.command_id in self._results
                        or self._stopped
                        or command.command_id in self._aborted
                    ),
                    self.timeout,
                ):
                    raise SkillError("driver_timeout", f"no result within {self.timeout} s")
                if self._stopped:  # the sim halts the arm itself on the same stop message
                    raise SkillError("stopped", "emergency stop during a trajectory")
                if command.command_id in self._aborted:
                    raise SkillError(
                        self._aborted[command.command_id], "the robot went away mid-trajectory"
                    )
                return self._results.pop(command.command_id)
        finally:
            with self._lock:
                self._waiting.discard(command.command_id)
                self._results.pop(command.command_id, None)
                self._aborted.pop(command.command_id, None)

    def joint_positions(self) -> np.ndarray:
        with self._lock:
            if not self._lock.wait_for(lambda: self._positions is not None, self.timeout):
                raise SkillError("driver_timeout", "no JointState from the robot yet")
            assert self._positions is not None
            return self._positions.copy()

    def object_position(self, object_id: str, after: float) -> np.ndarray | None:
        return object_seen_after(self._lock, lambda: self._scene, object_id, after)


class PandaSimDriver(PandaMotionDriver):
    """Registered as ``panda-sim`` (options: ``drivers.registry.PandaSimOptions``)."""

    name = "panda-sim"

    @classmethod
    def from_options(cls, bus: Bus, options: Any) -> PandaSimDriver:
        return cls(BusJointTransport(bus, options.timeout), options)
