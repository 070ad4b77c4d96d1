"""The robot going away between skills (the stack shutting down) is not a warning; while a
skill is under way it is, and that skill fails."""

from __future__ import annotations

import time

import pytest

from manigraph_shared.messages import SkillState, SkillStatus
from manigraph_skills.in_flight import ActionInFlight
from manigraph_testkit.testing import Stack


def test_under_way_from_begin_to_the_final_status_or_the_end() -> None:
    published: list[SkillStatus] = []
    flight = ActionInFlight(published.append, "pick_and_place")
    assert not flight.under_way
    flight.begin("d1")
    assert flight.under_way
    flight.report(
        SkillStatus(decision_id="d1", skill="pick_and_place", state=SkillState.SUCCEEDED, stamp=1.0)
    )
    assert not flight.under_way  # its final status went out
    flight.begin("d2")
    flight.end()
    assert not flight.under_way


@pytest.mark.integration
def test_the_sim_stopping_between_skills_warns_of_nothing(running_stack: Stack) -> None:
    running_stack.start("router")
    running_stack.start("sim", "sim")
    running_stack.start("skills", "skills")
    with running_stack.client() as bus:
        running_stack.wait_alive(bus, "sim", "skills")
        assert running_stack.stop("sim") == 0
        deadline = time.monotonic() + 10
        while "sim" in bus.alive_services(timeout=0.5) and time.monotonic() < deadline:
            time.sleep(0.1)
        time.sleep(1.0)  # the skills service has heard the token go
    running_stack.stop("skills")
    log = running_stack.log("skills")
    assert "ready" in log
    assert "went away" not in log and "WARNING" not in log, log
