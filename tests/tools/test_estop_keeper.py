"""The router's latch: kept on disk, answered to queries, engaged when its file is bad."""

from __future__ import annotations

import json
import time
from collections.abc import Iterator
from pathlib import Path

import pytest

from manigraph_shared.bus import Bus
from manigraph_shared.bus_config import BusConfig
from manigraph_shared.estop_latch import EstopLatch
from manigraph_shared.messages import EmergencyStop
from manigraph_testkit.testing import free_port
from manigraph_tools.estop_keeper import LATCH_FILE, EstopKeeper, state_dir


@pytest.fixture
def endpoint() -> str:
    return f"tcp/127.0.0.1:{free_port()}"


@pytest.fixture
def router(endpoint: str) -> Iterator[Bus]:
    with Bus.open(BusConfig(mode="router", listen=(endpoint,), connect=())) as bus:
        yield bus


def client(endpoint: str, cell: str | None = None) -> Bus:
    return Bus.open(BusConfig(connect=(endpoint,), wait_seconds=10.0, cell=cell))


def wait_for(condition, timeout: float = 5.0) -> None:  # type: ignore[no-untyped-def]
    deadline = time.monotonic() + timeout
    while not condition():
        assert time.monotonic() < deadline, "not within the time"
        time.sleep(0.02)


def test_a_stop_is_kept_on_disk_and_answered_after_the_router_restarts(
    router: Bus, endpoint: str, tmp_path: Path
) -> None:
    keeper = EstopKeeper(router.session, tmp_path)
    keeper.start()
    with client(endpoint) as bus:
        fresh = EstopLatch()
        assert fresh.ask(bus) and not fresh.engaged  # never engaged: released, and known
        time.sleep(0.2)
        bus.publish(EmergencyStop(engaged=True, reason="hand in cell", by="ana", stamp=1.0))
        wait_for(lambda: (tmp_path / LATCH_FILE).exists())
    keeper.close()

    # A new keeper on the same directory (a restarted router, a restarted `up`).
    again = EstopKeeper(router.session, tmp_path)
    again.start()
    try:
        with client(endpoint) as bus:
            latch = EstopLatch()
            assert latch.ask(bus)
            assert latch.engaged and latch.known and latch.state.reason == "hand in cell"
    finally:
        again.close()


def test_cells_are_latched_apart(router: Bus, endpoint: str, tmp_path: Path) -> None:
    keeper = EstopKeeper(router.session, tmp_path)
    keeper.start()
    try:
        with client(endpoint, cell="left") as left, client(endpoint, cell="right") as right:
            time.sleep(0.2)
            left.publish(EmergencyStop(engaged=True, reason="left only", stamp=2.0))
            wait_for(lambda: keeper.kept("manigraph/left/robot/estop").engaged)
            asks = EstopLatch(), EstopLatch()
            assert asks[0].ask(left) and asks[1].ask(right)
            assert asks[0].engaged and not asks[1].engaged
    finally:
        keeper.close()


@pytest.mark.parametrize("content", [b"{not json", b'{"stops": 3}', b"\x00" * 10])
def test_an_unreadable_latch_file_answers_engaged_until_resume(
    router: Bus, endpoint: str, tmp_path: Path, content: bytes
) -> None:
    (tmp_path / LATCH_FILE).write_bytes(content)
    keeper = EstopKeeper(router.session, tmp_path)
    keeper.start()
    try:
        with client(endpoint) as bus:
            latch = EstopLatch()
            assert latch.ask(bus)
            assert latch.engaged and "could not be read" in latch.state.reason
            time.sleep(0.2)
            bus.publish(EmergencyStop(engaged=False, reason="checked", stamp=3.0))
            wait_for(lambda: not keeper.kept("manigraph/robot/estop").engaged)
        saved = json.loads((tmp_path / LATCH_FILE).read_text())
        assert saved["stops"]["manigraph/robot/estop"]["engaged"] is False
    finally:
        keeper.close()


def test_no_latch_no_answer_and_the_service_stays_stopped(endpoint: str) -> None:
    router = Bus.open(BusConfig(mode="router", listen=(endpoint,), connect=()))
    with router, client(endpoint) as bus:
        latch = EstopLatch()
        assert not latch.ask(bus, timeout=0.3)
        assert latch.engaged and not latch.known


def test_the_state_directory_is_one_per_endpoint(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.delenv("MANIGRAPH_STATE_DIR", raising=False)
    monkeypatch.setenv("XDG_STATE_HOME", "/s")
    assert state_dir(None, ("tcp/127.0.0.1:7601",)) == Path("/s/manigraph/tcp-127.0.0.1-7601")
    assert state_dir(Path("/x"), ("tcp/127.0.0.1:7601",)) == Path("/x")
    monkeypatch.setenv("MANIGRAPH_STATE_DIR", "/y")
    assert state_dir(None, ()) == Path("/y")


def test_a_forged_answer_counts_for_nothing(endpoint: str) -> None:
    with Bus.open(BusConfig(mode="router", listen=(endpoint,), connect=())) as router:
        queryable = router.session.declare_queryable(
            "manigraph/robot/estop", lambda query: query.reply("manigraph/robot/estop", b"{}")
        )
        try:
            with client(endpoint) as bus:
                latch = EstopLatch()
                assert not latch.ask(bus, timeout=0.5)
                assert latch.engaged and not latch.known
        finally:
            queryable.undeclare()


def test_a_flood_of_repeated_stops_costs_a_write_a_second_and_a_change_is_written_at_once(
    router: Bus, endpoint: str, tmp_path: Path
) -> None:
    keeper = EstopKeeper(router.session, tmp_path)
    keeper.start()
    path = tmp_path / LATCH_FILE

    def on_disk() -> dict[str, object]:
        stops: dict[str, dict[str, object]] = json.loads(path.read_text())["stops"]
        return stops["manigraph/robot/estop"]

    try:
        with client(endpoint) as bus:
            time.sleep(0.2)
            bus.publish(EmergencyStop(engaged=True, reason="first", stamp=1.0))
            wait_for(lambda: keeper.kept("manigraph/robot/estop").engaged)
            assert on_disk()["reason"] == "first"  # a change of state: on disk before it is kept
            for n in range(300):
                bus.publish(EmergencyStop(engaged=True, reason=f"again {n}", stamp=2.0 + n))
            wait_for(lambda: keeper.kept("manigraph/robot/estop").reason == "again 299")
            assert keeper.writes <= 3  # not 301 fsyncs
            wait_for(lambda: on_disk()["reason"] == "again 299", timeout=3.0)  # within ~1 s

            bus.publish(EmergencyStop(engaged=False, reason="clear", stamp=400.0))
            wait_for(lambda: not keeper.kept("manigraph/robot/estop").engaged)
            assert on_disk()["engaged"] is False  # the release was written at once
    finally:
        keeper.close()
