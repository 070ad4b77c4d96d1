"""The service inbox stays bounded under a flood and keeps what it promises."""

from __future__ import annotations

import threading

import pytest

from manigraph_shared.inbox import Inbox


def handler(_: object) -> None:
    pass


def other(_: object) -> None:
    pass


def test_reliable_samples_beyond_capacity_are_dropped_and_counted_in_order() -> None:
    inbox = Inbox(capacity=3)
    accepted = [inbox.put(handler, i) for i in range(5)]
    assert accepted == [True, True, True, False, False]
    assert inbox.dropped == 2
    assert [inbox.get(0.0)[1] for _ in range(3)] == [0, 1, 2]  # type: ignore[index]
    assert inbox.get(0.0) is None
    assert inbox.put(handler, 9)  # room again once drained


def test_state_streams_keep_only_the_newest_waiting_sample_in_place() -> None:
    inbox = Inbox(capacity=2)
    inbox.put(handler, "first")
    for sequence in range(10_000):
        inbox.put_latest("scene", other, sequence)
    inbox.put(handler, "last")
    assert len(inbox) == 3 and inbox.coalesced == 9_999 and inbox.dropped == 0
    assert [inbox.get(0.0)[1] for _ in range(3)] == ["first", 9_999, "last"]  # type: ignore[index]


def test_the_services_own_work_is_never_dropped() -> None:
    inbox = Inbox(capacity=1)
    inbox.put(handler, "sample")
    for i in range(5):
        inbox.put_unbounded(handler, i)
    assert len(inbox) == 6 and inbox.dropped == 0


def test_get_waits_for_work_from_another_thread() -> None:
    inbox = Inbox()
    threading.Timer(0.05, inbox.put, (handler, "late")).start()
    work = inbox.get(timeout=2.0)
    assert work is not None and work[1] == "late"
    assert inbox.get(timeout=0.01) is None


def test_capacity_must_be_positive() -> None:
    with pytest.raises(ValueError, match="capacity"):
        Inbox(0)


def test_a_flood_in_one_lane_never_pushes_out_another_lanes_sample() -> None:
    inbox = Inbox(capacity=4)
    flood = [inbox.put(handler, f"status {i}") for i in range(2_000)]
    assert flood.count(True) == 4 and inbox.dropped == 1_996
    assert inbox.put(other, "robot command", lane="robot")  # its lane has room
    assert inbox.dropped_by_lane == {"default": 1_996}
    arrived = [inbox.get(0.0) for _ in range(5)]
    assert [work[1] for work in arrived if work] == [  # arrival order across lanes
        "status 0",
        "status 1",
        "status 2",
        "status 3",
        "robot command",
    ]


def test_each_lane_is_bounded_on_its_own() -> None:
    inbox = Inbox(capacity=2)
    assert [inbox.put(handler, i, lane="robot") for i in range(3)] == [True, True, False]
    assert inbox.dropped_by_lane == {"robot": 1}
    inbox.get(0.0)
    assert inbox.put(handler, 3, lane="robot")  # a slot freed in its own lane
