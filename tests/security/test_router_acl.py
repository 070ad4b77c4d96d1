"""A TLS router with access control: no certificate, no connection; the wrong identity, no effect.

A real router runs as a process on a free loopback port; the parties are real Zenoh sessions
presenting certificates made for this module. A forged message is sent first, the rightful
one after it, and the reader must receive only the rightful one.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Iterator
from pathlib import Path

import pytest
import zenoh
from acl_helpers import Inbox

from manigraph_shared.errors import BusError
from manigraph_shared.messages import (
    Action,
    EpisodeEvent,
    EpisodeRequest,
    Message,
    RobotCommand,
    Scene,
    SceneGoal,
    SceneObject,
    ServiceStatus,
    Vector3,
)
from manigraph_testkit.testing import Stack, open_raw_session, stack
from manigraph_tools.certificates import make_certificates

pytestmark = pytest.mark.integration
NOW = 1_700_000_000.0


@pytest.fixture(scope="module")
def router(certs: Path, tmp_path_factory: pytest.TempPathFactory) -> Iterator[Stack]:
    with stack(tmp_path_factory.mktemp("logs"), tls_dir=certs) as running:
        running.start("router")
        with running.client() as bus:  # waits until the router answers
            running.wait_alive(bus, "router")
        yield running


def action(tag: str) -> Action:
    return Action(
        decision_id=f"{tag}:0",
        episode_id=tag,
        scene_sequence=0,
        object_id="block_0",
        goal_id="goal_0",
        policy="expert",
        stamp=NOW,
    )


def robot_command(tag: str) -> RobotCommand:
    return RobotCommand(
        command_id=tag,
        decision_id=f"{tag}:0",
        op="place",
        object_id="block_0",
        position=Vector3(x=55.0, y=0.0, z=0.02),
        stamp=NOW,
    )


def scene(tag: str) -> Scene:
    return Scene(
        episode_id=tag,
        stamp=NOW,
        sequence=2**40,
        objects=[
            SceneObject(
                id="block_0",
                category="block",
                position=Vector3(x=0.5, y=0.1, z=0.02),
                size=Vector3(x=0.04, y=0.04, z=0.04),
            )
        ],
        goals=[SceneGoal(id="goal_0", category="block", position=Vector3(x=0.4, y=0, z=0.02))],
    )


def episode_event(tag: str) -> EpisodeEvent:
    return EpisodeEvent(
        episode_id=tag, phase="start", task="stack", seed=0, goals_total=1, goals_filled=0,
        stamp=NOW,
    )  # fmt: skip


CASES: list[tuple[Callable[[str], Message], str, str, str]] = [
    # (message, forger, rightful publisher, reader)
    (action, "recorder", "planner", "skills"),
    (action, "skills", "planner", "skills"),
    (action, "client", "planner", "skills"),
    (action, "view", "demo-ui", "skills"),  # a person deciding on the demonstration page
    (robot_command, "recorder", "skills", "sim"),
    (robot_command, "planner", "skills", "sim"),
    (scene, "recorder", "sim", "planner"),
    (scene, "planner", "perception", "skills"),
    (scene, "view", "sim", "planner"),
    (episode_event, "client", "sim", "recorder"),
]


@pytest.mark.parametrize(
    ("make", "forger", "rightful", "reader"),
    CASES,
    ids=[f"{make.__name__}-by-{forger}" for make, forger, _, _ in CASES],
)
def test_a_message_from_the_wrong_identity_is_dropped_at_the_router(
    router: Stack, make: Callable[[str], Message], forger: str, rightful: str, reader: str
) -> None:
    inbox = Inbox()
    with (
        router.client(identity=reader) as reading,
        router.client(identity=forger) as forging,
        router.client(identity=rightful) as publishing,
    ):
        reading.subscribe(type(make("x")), inbox.receive)
        time.sleep(0.3)  # the subscription reaches the router
        for _ in range(3):
            forging.publish(make("forged"))
        publishing.publish(make("rightful"))
        assert inbox.wait_for("rightful"), f"{rightful}'s message never arrived"
        time.sleep(0.2)
    assert inbox.tags == ["rightful"]


def test_only_the_episode_client_can_reset_the_world(router: Stack) -> None:
    resets: list[str] = []

    def reset(request: EpisodeRequest) -> EpisodeEvent:
        resets.append(request.episode_id)
        return episode_event(request.episode_id)

    with router.client(identity="sim") as sim:
        sim.serve(EpisodeRequest, reset)
        time.sleep(0.3)
        for forger in ("recorder", "planner", "skills", "view"):
            with router.client(identity=forger) as bus, pytest.raises(BusError, match="no answer"):
                bus.request(EpisodeRequest(episode_id=forger, task="stack"), EpisodeEvent, 1.0)
        with router.client(identity="client") as bus:
            answer = bus.request(EpisodeRequest(episode_id="run", task="stack"), EpisodeEvent)
    assert answer.episode_id == "run"
    assert resets == ["run"]


def test_no_one_but_the_sim_can_answer_resets(router: Stack) -> None:
    with router.client(identity="planner") as impostor:
        impostor.serve(EpisodeRequest, lambda request: episode_event("impostor"))
        time.sleep(0.3)
        with router.client(identity="client") as bus, pytest.raises(BusError, match="no answer"):
            bus.request(EpisodeRequest(episode_id="run", task="stack"), EpisodeEvent, 1.0)


def test_a_service_can_only_announce_itself(router: Stack) -> None:
    services: list[str] = []
    with router.client(identity="recorder") as recorder, router.client() as client:
        client.subscribe(ServiceStatus, lambda status: services.append(status.service))
        time.sleep(0.3)
        recorder.declare_alive("planner")
        recorder.publish(ServiceStatus(service="planner", state="ok", stamp=NOW))
        recorder.declare_alive("recorder")
        recorder.publish(ServiceStatus(service="recorder", state="ok", stamp=NOW))
        time.sleep(0.5)
        alive = client.alive_services(timeout=1.0)
    assert "recorder" in alive and "planner" not in alive
    assert services == ["recorder"]


def test_a_client_without_a_certificate_cannot_connect(router: Stack, certs: Path) -> None:
    with pytest.raises(zenoh.ZError):  # the server is trusted, but it wants our certificate
        open_raw_session(router.endpoint, root_ca_certificate=str(certs / "ca.pem"))
    with pytest.raises(zenoh.ZError):  # plain TCP to the TLS port
        open_raw_session(router.endpoint.replace("tls/", "tcp/"))


def test_a_certificate_from_another_ca_cannot_connect(
    router: Stack, certs: Path, tmp_path: Path
) -> None:
    make_certificates(tmp_path, ["planner"])  # same name, a CA the router does not trust
    with pytest.raises(zenoh.ZError):
        open_raw_session(
            router.endpoint,
            root_ca_certificate=str(certs / "ca.pem"),
            connect_certificate=str(tmp_path / "planner.pem"),
            connect_private_key=str(tmp_path / "planner.key"),
        )
