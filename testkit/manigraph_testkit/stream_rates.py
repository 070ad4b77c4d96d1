"""How often the sim streamed Scene and JointState, read from a recorded MCAP log.

``manigraph up --sim physics --realtime --record run.mcap`` streams as a robot does; this says
what reached the recorder: per episode, the scenes' rate and their longest gap, and the joint
states' rate while the arm moved (the last ``duration`` seconds before each successful
``JointTrajectoryResult``, which is stamped when the motion ended; ``duration`` is its
command's). Rates use the publishers' stamps and count the samples the recorder received.
"""

from __future__ import annotations

import statistics
from dataclasses import asdict, dataclass
from itertools import pairwise
from pathlib import Path

from manigraph_shared.mcap_log import decode_log
from manigraph_shared.messages import (
    JointState,
    JointTrajectoryCommand,
    JointTrajectoryResult,
    Scene,
)


@dataclass(frozen=True)
class EpisodeStreams:
    episode_id: str
    scenes: int
    scene_hz: float
    #: Longest time between two consecutive scenes of the episode.
    scene_gap_max: float
    #: Seconds the arm moved (the trajectories' durations, summed).
    moving_seconds: float
    joint_states_moving: int
    joint_state_hz_moving: float


def stream_rates(path: Path) -> list[EpisodeStreams]:
    """Per episode in ``path``: its Scene and moving JointState rates."""
    messages = decode_log(
        path,
        [Scene.key, JointState.key, JointTrajectoryCommand.key, JointTrajectoryResult.key],
    )
    scenes: dict[str, list[float]] = {}
    for m in messages:
        if isinstance(m, Scene):
            scenes.setdefault(m.episode_id, []).append(m.stamp)
    # A motion ends at its result's stamp and lasted at least its trajectory's duration (the
    # sim settles after it, and falls behind the clock under load, never ahead of it).
    duration = {
        m.command_id: m.points[-1].time_from_start
        for m in messages
        if isinstance(m, JointTrajectoryCommand)
    }
    motions = sorted(
        (m.stamp - duration[m.command_id], m.stamp)
        for m in messages
        if isinstance(m, JointTrajectoryResult) and m.ok and m.command_id in duration
    )
    joint_stamps = sorted(m.stamp for m in messages if isinstance(m, JointState))
    results = []
    for episode_id, stamps in scenes.items():
        stamps.sort()
        first, last = stamps[0], stamps[-1]
        inside = [(a, b) for a, b in motions if first <= a and b <= last]
        moving = sum(b - a for a, b in inside)
        count = sum(1 for t in joint_stamps for a, b in inside if a <= t <= b)
        span = last - first
        results.append(
            EpisodeStreams(
                episode_id=episode_id,
                scenes=len(stamps),
                scene_hz=round((len(stamps) - 1) / span, 2) if span > 0 else 0.0,
                scene_gap_max=round(max((b - a for a, b in pairwise(stamps)), default=0.0), 3),
                moving_seconds=round(moving, 3),
                joint_states_moving=count,
                joint_state_hz_moving=round(count / moving, 2) if moving > 0 else 0.0,
            )
        )
    return results


def summary(streams: list[EpisodeStreams]) -> dict[str, object]:
    """Medians over the episodes, and every episode's figures."""
    if not streams:
        return {"episodes": 0}
    return {
        "episodes": len(streams),
        "scene_hz": statistics.median(s.scene_hz for s in streams),
        "scene_gap_max": max(s.scene_gap_max for s in streams),
        "joint_state_hz_moving": statistics.median(s.joint_state_hz_moving for s in streams),
        "per_episode": [asdict(s) for s in streams],
    }
