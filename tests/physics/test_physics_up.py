"""One short physics episode through the full stack: router, physics sim, planner and skills
(Panda driver) as separate processes over real Zenoh on loopback."""

from __future__ import annotations

import json

import pytest

from manigraph_tools.testing import run_up

pytestmark = pytest.mark.integration


def test_a_physics_stacking_episode_through_every_service() -> None:
    result = run_up(
        "--sim",
        "physics",
        "--task",
        "stack",
        "--blocks",
        "2",
        "--episodes",
        "1",
        "--seed",
        "3",
        timeout=120.0,
    )
    summary = json.loads(result.stdout.strip().splitlines()[-1])
    assert summary["success_rate"] == 1.0
    (episode,) = summary["results"]
    assert episode["goals_filled"] == episode["goals_total"] == 2
    assert episode["steps"] == 2
    assert "driver 'panda-sim'" in result.stderr  # up chose the Panda driver for physics
