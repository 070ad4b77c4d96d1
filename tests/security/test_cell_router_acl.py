"""Access control per robot cell at a real TLS router: cell A's identities cannot move cell B's
robot, decide for it or reset its world; the rightful identity of each cell still can.

Every forged message is sent several times before the rightful one; the reader must receive
the rightful one only, so each forged copy is a refusal at the router (counted).
"""

from __future__ import annotations

import json
import time
from collections.abc import Callable, Iterator
from dataclasses import replace

import pytest
from acl_helpers import Inbox

from manigraph_shared.bus import Bus
from manigraph_shared.errors import BusError
from manigraph_shared.messages import (
    Action,
    EpisodeEvent,
    EpisodeRequest,
    Message,
    RobotCommand,
    Vector3,
)
from manigraph_testkit.testing import Stack, stack
from manigraph_tools.access import cell_identities, write_cell_identities
from manigraph_tools.certificates import IDENTITIES, make_certificates

pytestmark = pytest.mark.integration
NOW = 1_700_000_000.0
FORGED_COPIES = 3
CELLS = {**cell_identities(["cell-1", "cell-2"]), "planner.pool": ("cell-1", "cell-2")}


@pytest.fixture(scope="module")
def router(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Stack]:
    certs = tmp_path_factory.mktemp("cell-certs")
    make_certificates(certs, [*IDENTITIES, *CELLS])
    write_cell_identities(certs, CELLS)
    with stack(tmp_path_factory.mktemp("logs"), tls_dir=certs) as running:
        running.start("router")
        with running.client() as bus:  # waits until the router answers
            running.wait_alive(bus, "router")
        assert f"{len(CELLS)} cell identities" in running.log("router")
        yield running


def open_as(router: Stack, identity: str, cell: str | None) -> Bus:
    return Bus.open(replace(router.bus_config(identity), cell=cell))


def action(tag: str) -> Action:
    return Action(
        decision_id=f"{tag}:0", episode_id=tag, scene_sequence=0, object_id="block_0",
        goal_id="goal_0", policy="expert", stamp=NOW,
    )  # fmt: skip


def robot_command(tag: str) -> RobotCommand:
    return RobotCommand(
        command_id=tag, decision_id=f"{tag}:0", op="place", object_id="block_0",
        position=Vector3(x=0.5, y=0.0, z=0.02), stamp=NOW,
    )  # fmt: skip


CASES: list[tuple[Callable[[str], Message], str, str, str, str]] = [
    # (message, in cell, forger, rightful publisher, reader)
    (robot_command, "cell-1", "skills.cell-2", "skills.cell-1", "sim.cell-1"),
    (robot_command, "cell-2", "skills.cell-1", "skills.cell-2", "sim.cell-2"),
    (robot_command, "cell-1", "skills", "skills.cell-1", "sim.cell-1"),  # the default cell's
    (robot_command, "cell-1", "planner.pool", "skills.cell-1", "sim.cell-1"),
    (action, "cell-1", "planner.cell-2", "planner.cell-1", "skills.cell-1"),
    (action, "cell-2", "planner.cell-1", "planner.pool", "skills.cell-2"),
    (action, "cell-2", "demo-ui.cell-1", "planner.cell-2", "skills.cell-2"),
]


@pytest.mark.parametrize(
    ("make", "cell", "forger", "rightful", "reader"),
    CASES,
    ids=[f"{make.__name__}-in-{cell}-by-{forger}" for make, cell, forger, _, _ in CASES],
)
def test_another_cells_identity_is_refused_at_the_router(
    router: Stack,
    make: Callable[[str], Message],
    cell: str,
    forger: str,
    rightful: str,
    reader: str,
) -> None:
    inbox = Inbox()
    with (
        open_as(router, reader, cell) as reading,
        open_as(router, forger, cell) as forging,
        open_as(router, rightful, cell) as publishing,
    ):
        reading.subscribe(type(make("x")), inbox.receive)
        time.sleep(0.3)  # the subscription reaches the router
        for copy in range(FORGED_COPIES):
            forging.publish(make(f"forged-{copy}"))
        publishing.publish(make("rightful"))
        assert inbox.wait_for("rightful"), f"{rightful}'s message never arrived"
        time.sleep(0.2)
    assert inbox.tags == ["rightful"], f"{len(inbox.tags) - 1} forged copies got through"


def test_only_the_cells_own_client_resets_its_world(router: Stack) -> None:
    resets: list[str] = []

    def reset(request: EpisodeRequest) -> EpisodeEvent:
        resets.append(request.episode_id)
        return EpisodeEvent(
            episode_id=request.episode_id, phase="start", task="stack", seed=0, goals_total=1,
            goals_filled=0, stamp=NOW,
        )  # fmt: skip

    refused = 0
    with open_as(router, "sim.cell-1", "cell-1") as sim:
        sim.serve(EpisodeRequest, reset)
        time.sleep(0.3)
        for forger in ("client.cell-2", "client", "sim.cell-2", "planner.pool"):
            with (
                open_as(router, forger, "cell-1") as bus,
                pytest.raises(BusError, match="no answer"),
            ):
                bus.request(EpisodeRequest(episode_id=forger, task="stack"), EpisodeEvent, 1.0)
            refused += 1
        with open_as(router, "client.cell-1", "cell-1") as bus:
            answer = bus.request(EpisodeRequest(episode_id="run", task="stack"), EpisodeEvent)
    assert answer.episode_id == "run"
    assert resets == ["run"] and refused == 4


def test_a_cell_identity_cannot_serve_another_cells_resets(router: Stack) -> None:
    with open_as(router, "sim.cell-2", "cell-1") as impostor:
        impostor.serve(EpisodeRequest, lambda request: None)  # type: ignore[arg-type,return-value]
        time.sleep(0.3)
        with (
            open_as(router, "client.cell-1", "cell-1") as bus,
            pytest.raises(BusError, match="no answer"),
        ):
            bus.request(EpisodeRequest(episode_id="run", task="stack"), EpisodeEvent, 1.0)


def test_up_secure_runs_each_cell_under_its_own_identities() -> None:
    from manigraph_testkit.testing import run_up

    result = run_up("--secure", "--cells", "2", "--blocks", "3", "--episodes", "1", "--json")
    summary = json.loads(result.stdout.strip().splitlines()[-1])
    assert summary["success_rate_by_cell"] == {"cell-1": 1.0, "cell-2": 1.0}
    assert "(mutual TLS + access control)" in result.stderr
