"""A service's view of the emergency stop: unknown is stopped, heard stops apply in arrival
order, and a latch answer that a heard stop overtook is stale."""

from __future__ import annotations

from manigraph_shared.estop_latch import ESTOP_ENGAGED, EstopLatch
from manigraph_shared.messages import EmergencyStop, EstopState


def stop(engaged: bool, stamp: float, reason: str = "") -> EmergencyStop:
    return EmergencyStop(engaged=engaged, reason=reason, by="test", stamp=stamp)


def test_a_service_that_has_not_heard_the_latch_acts_as_stopped() -> None:
    latch = EstopLatch()
    assert latch.engaged and not latch.known
    assert latch.describe().startswith(ESTOP_ENGAGED)
    assert "not yet known" in latch.describe()


def test_heard_stops_apply_in_arrival_order_whatever_their_stamps() -> None:
    changes: list[EstopState] = []
    latch = EstopLatch(on_change=changes.append)
    latch.heard(stop(True, 100.0, "jam"))
    latch.heard(stop(False, 90.0, "cleared"))  # a second operator's clock is behind
    assert not latch.engaged and latch.known
    assert [(c.engaged, c.known) for c in changes] == [(True, True), (False, True)]


def test_the_latch_answer_teaches_a_service_that_missed_the_stop() -> None:
    latch = EstopLatch()
    latch.answered([stop(True, 50.0, "pinch")], heard_before=0)
    assert latch.engaged and latch.known and latch.state.reason == "pinch"


def test_an_answer_overtaken_by_a_heard_stop_is_ignored() -> None:
    latch = EstopLatch()
    latch.answered([stop(False, 0.0)], heard_before=0)
    asked_when = 0
    latch.heard(stop(True, 10.0, "now"))  # heard while the next query was under way
    latch.answered([stop(False, 0.0)], heard_before=asked_when)
    assert latch.engaged and latch.state.reason == "now"


def test_of_several_routers_the_newest_answer_wins_and_engaged_breaks_a_tie() -> None:
    latch = EstopLatch()
    latch.answered([stop(True, 5.0, "old"), stop(False, 9.0, "resumed")], heard_before=0)
    assert not latch.engaged
    tie = EstopLatch()
    tie.answered([stop(False, 9.0), stop(True, 9.0, "tie")], heard_before=0)
    assert tie.engaged


def test_no_change_no_callback() -> None:
    changes: list[EstopState] = []
    latch = EstopLatch(on_change=changes.append)
    latch.answered([stop(False, 0.0)], heard_before=0)
    latch.answered([stop(False, 0.0)], heard_before=0)
    assert len(changes) == 1
