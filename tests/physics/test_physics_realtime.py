"""The physics stack in real time, as a robot runs: router, physics sim (``--realtime``),
planner and skills as separate processes over real Zenoh on loopback, recorded to MCAP."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from manigraph_testkit.stream_rates import stream_rates
from manigraph_testkit.testing import run_up, spare_core_problem

pytestmark = pytest.mark.integration


@pytest.fixture(autouse=True)
def a_spare_core() -> None:
    """These tests measure real-time rates: the sim's loop needs a core when it steps. On a
    machine that cannot give it one they say so and skip, rather than pass on looser bounds
    (a 1.15 s gap between scenes was a sim descheduled on an oversubscribed machine)."""
    problem = spare_core_problem()
    if problem:
        pytest.skip(problem)


def test_a_realtime_episode_takes_its_simulated_time_and_streams_like_a_robot(
    tmp_path: Path,
) -> None:
    log = tmp_path / "realtime.mcap"
    result = run_up(
        "--sim",
        "physics",
        "--realtime",
        "--task",
        "stack",
        "--blocks",
        "2",
        "--episodes",
        "1",
        "--seed",
        "7",
        "--record",
        str(log),
        "--json",
        timeout=300.0,
    )
    summary = json.loads(result.stdout.strip().splitlines()[-1])
    # A failure says why (its reason, and the services' last log lines): once, under load 4,
    # this episode failed with nothing more than "success 0.0" to go on.
    assert summary["success_rate"] == 1.0, (summary["results"], result.stderr[-3000:])
    (episode,) = summary["results"]
    simulated, wall = episode["sim_seconds"], episode["seconds"]
    # Two PickAndPlaces are seconds of motion; flat out they take a thirtieth of that.
    assert simulated > 4.0
    assert wall >= 0.95 * simulated, f"{wall} s wall for {simulated} s simulated"
    assert summary["realtime_factor"] <= 1.05

    (streams,) = stream_rates(log)
    # 30 Hz (the default --scene-hz) within 20 %, also while the arm moves: without streaming
    # the service thread is inside each motion (the longest lasts 1-3 s) and no scene comes
    # out until it ends. Gaps up to 0.28 s were seen at load 58 on 2 cores.
    assert 24.0 <= streams.scene_hz <= 36.0, streams
    assert streams.scene_gap_max < 0.5, streams
    # 100 Hz joint states (--joint-state-hz) during motions: 80-93 Hz measured at load 38 on
    # 2 cores (a step late by more than a period skips a sample); flat out: none at all.
    assert streams.moving_seconds > 0.8 * simulated - 1.0, streams
    assert 55.0 <= streams.joint_state_hz_moving <= 110.0, streams


def test_realtime_stream_rates_reach_the_sim_from_up(tmp_path: Path) -> None:
    log = tmp_path / "slow.mcap"
    result = run_up(
        "--sim",
        "physics",
        "--realtime",
        "--scene-hz",
        "10",
        "--joint-state-hz",
        "40",
        "--task",
        "stack",
        "--blocks",
        "1",
        "--episodes",
        "1",
        "--record",
        str(log),
        "--json",
        timeout=300.0,
    )
    summary = json.loads(result.stdout.strip().splitlines()[-1])
    assert summary["success_rate"] == 1.0, (summary["results"], result.stderr[-3000:])
    (streams,) = stream_rates(log)
    assert 8.0 <= streams.scene_hz <= 12.0, streams
    assert 22.0 <= streams.joint_state_hz_moving <= 44.0, streams
