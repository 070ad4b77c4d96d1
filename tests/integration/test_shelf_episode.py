"""The shelf family through the real services: router, sim, planner and skills on loopback."""

from __future__ import annotations

import json

import pytest

from manigraph_testkit.testing import run_up

pytestmark = pytest.mark.integration


def test_up_fills_a_shelf_with_its_expert() -> None:
    result = run_up(
        "--task",
        "shelf",
        "--objects",
        "4",
        "--episodes",
        "2",
        "--seed",
        "53920",
        "--policy",
        "shelf-expert",
        timeout=120,
    )
    summary = json.loads(result.stdout.strip().splitlines()[-1])
    assert summary["task"] == "shelf" and summary["objects"] == 4
    assert summary["success_rate"] == 1.0 and summary["mean_steps"] == 4.0
