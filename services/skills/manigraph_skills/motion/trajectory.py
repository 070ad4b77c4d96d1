"""Time-parameterised joint trajectories: joint waypoints with times and a gripper target.

A straight segment of samples is timed with a minimum-jerk profile,
``s(t) = 10 tau^3 - 15 tau^4 + 6 tau^5`` with ``tau = t / T``, so velocity and acceleration
are zero at both ends; its peak speed is ``1.875 L / T``. ``T`` is the shortest duration that
keeps both the Cartesian speed and every joint's speed under their limits.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

#: Peak over mean speed of the minimum-jerk profile.
MIN_JERK_PEAK = 1.875


def min_jerk(tau: np.ndarray) -> np.ndarray:
    tau = np.clip(tau, 0.0, 1.0)
    return tau**3 * (10 - 15 * tau + 6 * tau**2)


@dataclass
class JointTrajectory:
    """Points ``positions[i]`` (radians, arm joints) to be reached at ``times[i]`` seconds from
    the start, with the gripper commanded ``closed[i]`` while moving towards point ``i``, and
    open ``opening`` metres wide where it is not closed (None: fully)."""

    times: list[float] = field(default_factory=list)
    positions: list[np.ndarray] = field(default_factory=list)
    closed: list[bool] = field(default_factory=list)
    opening: float | None = None

    @property
    def duration(self) -> float:
        return self.times[-1] if self.times else 0.0

    @property
    def final(self) -> np.ndarray:
        return self.positions[-1]

    def __len__(self) -> int:
        return len(self.times)

    def add(self, t: float, q: np.ndarray, closed: bool) -> None:
        if self.times and t <= self.times[-1]:
            raise ValueError(f"times: {t} does not follow {self.times[-1]}")
        self.times.append(float(t))
        self.positions.append(np.array(q, dtype=float))
        self.closed.append(bool(closed))

    def add_segment(
        self,
        path: np.ndarray,
        closed: bool,
        length: float,
        speed: float,
        joint_speed: np.ndarray,
    ) -> None:
        """Append the joint samples ``path[1:]`` (``path[0]`` is where the arm already is),
        evenly spaced along a Cartesian segment of ``length`` metres."""
        steps = len(path) - 1
        if steps < 1:
            return
        joint_travel = np.abs(np.diff(path, axis=0)).sum(axis=0)
        duration = MIN_JERK_PEAK * max(length / speed, float(np.max(joint_travel / joint_speed)))
        duration = max(duration, 0.05)
        # Invert s(t) on a dense table: the time at which each evenly spaced sample is due.
        dense_t = np.linspace(0.0, duration, 256)
        arrival = np.interp(np.arange(1, steps + 1) / steps, min_jerk(dense_t / duration), dense_t)
        start = self.duration
        for t, q in zip(arrival, path[1:], strict=True):
            self.add(start + max(float(t), 1e-3), q, closed)

    def hold(self, duration: float, closed: bool) -> None:
        """Stay where the last point is for ``duration`` s (e.g. while the gripper moves)."""
        self.add(self.duration + duration, self.final, closed)

    def sample(self, t: float) -> np.ndarray:
        """Joint positions at ``t`` by linear interpolation between the points."""
        times = np.asarray(self.times)
        stack = np.asarray(self.positions)
        return np.array([np.interp(t, times, stack[:, j]) for j in range(stack.shape[1])])
