"""The Franka driver: the real franky library, with only its robot and hand objects faked
(the hardware boundary); what they were asked to do is recorded and checked."""

from __future__ import annotations

import threading
import time
from collections.abc import Iterator

import numpy as np
import pytest

from manigraph_shared.bus import Bus
from manigraph_shared.bus_config import BusConfig
from manigraph_shared.errors import ConfigError, SkillError
from manigraph_shared.messages import (
    GripperTarget,
    JointTrajectoryCommand,
    JointTrajectoryPoint,
    Quaternion,
    Vector3,
)
from manigraph_shared.panda import ARM_JOINTS
from manigraph_shared.workspace import Workspace
from manigraph_skills.drivers import DRIVERS
from manigraph_skills.drivers.base import Grasp, Motion, TrayToggle
from manigraph_skills.drivers.franka import FrankaDriver
from manigraph_skills.drivers.franka_config import FrankaConfig
from manigraph_testkit.testing import free_port

franky = pytest.importorskip("franky")

BLOCK = Vector3(x=0.5, y=0.1, z=0.02)
GOAL = Vector3(x=0.4, y=-0.2, z=0.06)
#: A Panda at rest near Franka's "ready" pose.
READY = np.array([0.0, -0.785, 0.0, -2.356, 0.0, 1.571, 0.785])


class FakeRobot:
    """Stands in for ``franky.Robot``: holds joints, records every call."""

    def __init__(self, address: str, **options: object) -> None:
        self.address = address
        self.options = options
        self.q = READY.copy()
        self.calls: list[str] = []
        self.motions: list[object] = []
        FakeRobot.last = self

    last: FakeRobot | None = None

    @property
    def current_joint_positions(self) -> np.ndarray:
        return self.q.copy()

    def set_collision_behavior(self, torque: float, force: float) -> None:
        self.calls.append(f"collision {torque} {force}")

    def move(self, motion: object) -> None:
        self.calls.append("move")
        self.motions.append(motion)
        self.q = np.array(motion.waypoints[-1].target.position)  # type: ignore[attr-defined]

    def stop(self) -> None:
        self.calls.append("stop")


class FakeGripper:
    """Stands in for ``franky.Gripper``: a 4 cm block is between the fingers when closed."""

    def __init__(self, address: str) -> None:
        self.width = 0.08
        self.calls: list[str] = []
        FakeGripper.last = self

    last: FakeGripper | None = None

    def grasp(self, width: float, speed: float, force: float, inner: float, outer: float) -> bool:
        self.calls.append(f"grasp {force}")
        self.width = 0.04
        return True

    def move(self, width: float, speed: float) -> bool:
        self.calls.append(f"move {width}")
        self.width = width
        return True


def driver(**fields: object) -> FrankaDriver:
    config = FrankaConfig(**{"address": "172.16.0.2", "realtime": False, **fields})  # type: ignore[arg-type]
    return FrankaDriver(config=config, robot_class=FakeRobot, gripper_class=FakeGripper)


@pytest.fixture
def bus_pair() -> Iterator[tuple[Bus, Bus]]:
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    first = Bus.open(BusConfig(mode="peer", listen=(endpoint,), connect=()))
    second = Bus.open(BusConfig(mode="peer", connect=(endpoint,)))
    yield first, second
    second.close()
    first.close()


def test_franka_is_a_registered_driver_with_a_dry_run() -> None:
    assert DRIVERS["franka"] is FrankaDriver
    assert DRIVERS.options("franka", {"dry_run": True}).dry_run
    with pytest.raises(ConfigError, match="dry_run"):
        DRIVERS.options("panda-sim", {"dry_run": True})  # only franka has a dry run


def test_a_dry_run_pick_and_place_plans_validates_publishes_and_moves_nothing(
    bus_pair: tuple[Bus, Bus],
) -> None:
    bus, listener = bus_pair
    seen: list[JointTrajectoryCommand] = []
    listener.subscribe(JointTrajectoryCommand, seen.append)
    time.sleep(0.5)  # the subscription reaches the publisher's session
    config = FrankaConfig(address="172.16.0.2", realtime=False, dry_run=True)
    franka = FrankaDriver(bus, config, robot_class=FakeRobot, gripper_class=FakeGripper)
    franka.pick(Motion("e:0", "block_0", BLOCK, Quaternion()))
    franka.place(Motion("e:0", "block_0", GOAL, Quaternion()))
    robot, gripper = FakeRobot.last, FakeGripper.last
    assert robot is not None and gripper is not None
    assert "move" not in robot.calls and robot.motions == []  # the arm never moved
    assert gripper.calls == []  # nor did the hand
    deadline = time.monotonic() + 5
    while len(seen) < 3 and time.monotonic() < deadline:
        time.sleep(0.05)
    pick, carry, release = seen  # every planned motion is on the bus, so in the MCAP log
    assert np.allclose(pick.points[0].positions, READY)  # planned from the robot's joints
    assert pick.points[-1].gripper is GripperTarget.CLOSED
    assert release.points[-1].gripper is GripperTarget.OPEN
    assert np.allclose(carry.points[0].positions, pick.points[-1].positions)


def test_a_motion_runs_as_franky_waypoints_with_the_hand_between() -> None:
    franka = driver(speed_factor=0.5)
    franka.pick(Motion("e:0", "block_0", BLOCK, Quaternion()))
    robot, gripper = FakeRobot.last, FakeGripper.last
    assert robot is not None and gripper is not None
    assert robot.options["realtime_config"] == franky.RealtimeConfig.Ignore
    assert robot.relative_dynamics_factor == 0.5  # type: ignore[attr-defined]
    assert robot.calls[0] == "collision 20.0 30.0"
    # Down to the block, close the hand, lift: two arm motions around one grasp.
    assert robot.calls[1:] == ["move", "move"]
    assert gripper.calls == ["grasp 20.0"]
    first = robot.motions[0]
    assert all(isinstance(w, franky.JointWaypoint) for w in first.waypoints)  # type: ignore[attr-defined]
    assert first.waypoints[-1].minimum_time is not None  # type: ignore[attr-defined]


def test_the_hand_opens_as_wide_as_each_grasp_asks() -> None:
    franka = driver()
    narrow = Grasp(opening=0.035)
    franka.pick(Motion("e:0", "plate_0", BLOCK, Quaternion(), narrow))
    franka.place(Motion("e:0", "plate_0", GOAL, Quaternion(), narrow))
    gripper = FakeGripper.last
    assert gripper is not None
    # Opened to 3.5 cm before coming down, closed on the dish, let go of at 3.5 cm.
    assert gripper.calls == ["move 0.035", "grasp 20.0", "move 0.035"]


def test_a_trajectory_over_the_velocity_limit_is_refused_naming_the_joint() -> None:
    franka = driver(speed_factor=1.0)
    too_fast = READY.copy()
    too_fast[3] += 1.0  # one radian of the elbow in a tenth of a second: 10 rad/s
    command = JointTrajectoryCommand(
        command_id="e:0.0",
        decision_id="e:0",
        joint_names=list(ARM_JOINTS),
        points=[
            JointTrajectoryPoint(
                positions=READY.tolist(), gripper=GripperTarget.OPEN, time_from_start=0.0
            ),
            JointTrajectoryPoint(
                positions=too_fast.tolist(), gripper=GripperTarget.OPEN, time_from_start=0.1
            ),
        ],
        stamp=1.0,
    )
    with pytest.raises(SkillError) as caught:
        franka.transport.execute(command)
    assert caught.value.reason == "limit_exceeded"
    assert "panda_joint4 velocity" in caught.value.detail
    assert FakeRobot.last is not None and "move" not in FakeRobot.last.calls


def test_a_target_outside_the_workspace_is_refused_before_any_motion() -> None:
    franka = driver(workspace=Workspace(x=(0.15, 0.45), y=(-0.6, 0.6), z=(0.01, 0.8)))
    with pytest.raises(SkillError) as caught:
        franka.pick(Motion("e:0", "block_0", BLOCK, Quaternion()))  # at x = 0.5
    assert caught.value.reason == "limit_exceeded"
    assert "TCP x" in caught.value.detail
    assert FakeRobot.last is not None and "move" not in FakeRobot.last.calls


def test_no_robot_at_the_address_is_a_clear_error_within_the_timeout() -> None:
    # The real library: nothing listens on loopback's FCI port, so it is refused at once.
    config = FrankaConfig(address="127.0.0.1", realtime=False, connect_timeout=2.0)
    started = time.monotonic()
    with pytest.raises(ConfigError) as caught:
        FrankaDriver(config=config)
    assert time.monotonic() - started < 3.0
    assert caught.value.field == "franka.address"
    assert "127.0.0.1" in caught.value.problem


def test_a_robot_that_never_answers_is_given_up_after_the_timeout() -> None:
    release = threading.Event()

    class SilentRobot(FakeRobot):
        def __init__(self, address: str, **options: object) -> None:
            release.wait(30)  # an address where packets vanish: libfranka waits 60 s

    config = FrankaConfig(address="192.0.2.1", realtime=False, connect_timeout=0.5)
    started = time.monotonic()
    with pytest.raises(ConfigError) as caught:
        FrankaDriver(config=config, robot_class=SilentRobot, gripper_class=FakeGripper)
    release.set()
    assert time.monotonic() - started < 2.0
    assert "192.0.2.1 within 0.5 s" in caught.value.problem


@pytest.mark.parametrize(
    ("fields", "field"),
    [
        ({"speed_factor": 1.5}, "franka.speed_factor"),
        ({"grasp_force": 0.0}, "franka.grasp_force"),
        ({"address": ""}, "franka.address"),
        ({"address": "not an address!"}, "franka.address"),
        ({"connect_timeout": 120.0}, "franka.connect_timeout"),
    ],
)
def test_bad_configuration_names_the_field(fields: dict[str, object], field: str) -> None:
    with pytest.raises(ConfigError) as caught:
        FrankaConfig(**{"address": "172.16.0.2", **fields})  # type: ignore[arg-type]
    assert caught.value.field == field


def test_configuration_comes_from_the_environment_with_the_variable_named() -> None:
    config = FrankaConfig.from_env(
        {
            "MANIGRAPH_FRANKA_ADDRESS": "robot.local",
            "MANIGRAPH_FRANKA_SPEED_FACTOR": "0.2",
            "MANIGRAPH_FRANKA_GRIPPER": "0",
            "MANIGRAPH_FRANKA_WORKSPACE": "0.2,0.8,-0.4,0.4,0.02,0.6",
        }
    )
    assert (config.address, config.speed_factor, config.gripper) == ("robot.local", 0.2, False)
    assert config.workspace.z == (0.02, 0.6)
    with pytest.raises(ConfigError) as caught:
        FrankaConfig.from_env(
            {"MANIGRAPH_FRANKA_ADDRESS": "r", "MANIGRAPH_FRANKA_GRASP_FORCE": "x"}
        )
    assert caught.value.field == "franka.grasp_force (MANIGRAPH_FRANKA_GRASP_FORCE)"


def top_rack(handle: Vector3, is_open: bool, **measured: float | None) -> TrayToggle:
    """The top rack's toggle as the dishwasher family asks it of a driver (its tab and rail)."""
    from manigraph_dishwasher.fixtures import Rack
    from manigraph_dishwasher.skills.trays import tray_toggle

    rack = Rack(id="rack_top", position=handle, open=is_open, **measured)
    return tray_toggle("e:0", rack)


def test_a_rack_toggle_runs_through_franky_grasp_slide_release() -> None:
    from manigraph_skills.motion import PandaModel

    franka = driver()
    handle = Vector3(x=0.51, y=0.0, z=0.30)  # the top rack pulled out (docs/dishwasher.md)
    franka.toggle_tray(top_rack(handle, True))  # push it in
    robot, gripper = FakeRobot.last, FakeGripper.last
    assert robot is not None and gripper is not None
    # Down to the handle, close, slide along the rail; open, back off: three arm motions.
    assert robot.calls[1:] == ["move", "move", "move"]
    assert gripper.calls == ["grasp 20.0", "move 0.08"]
    model = PandaModel()

    def tcp(motion: object) -> np.ndarray:
        q = np.array(motion.waypoints[-1].target.position)  # type: ignore[attr-defined]
        return model.tcp_pose(q).translation

    grasped, slid = tcp(robot.motions[0]), tcp(robot.motions[1])
    assert np.allclose(slid - grasped, [0.16, 0.0, 0.0], atol=0.005)  # the rail's length
    # At the tab (rack_geometry.rack_grip): beside the rack's right side, in front of it.
    assert np.allclose(grasped[:2], [0.51 - 0.08, 0.44], atol=0.005)


def test_a_rack_part_of_the_way_out_slides_only_as_far_as_it_has_left_to_go() -> None:

    franka = driver()
    handle = Vector3(x=0.57, y=0.0, z=0.30)  # the top rack 10 cm out
    franka.toggle_tray(top_rack(handle, True, travel=0.10))  # push it in
    grasped, slid = _grasped_and_slid()
    assert np.allclose(slid - grasped, [0.10, 0.0, 0.0], atol=0.005)


def _grasped_and_slid() -> tuple[np.ndarray, np.ndarray]:
    """Where the TCP ended the last toggle's first two motions: at the handle, and slid."""
    from manigraph_skills.motion import PandaModel

    robot = FakeRobot.last
    assert robot is not None
    model = PandaModel()
    grasped, slid = (
        model.tcp_pose(np.array(m.waypoints[-1].target.position)).translation  # type: ignore[attr-defined]
        for m in robot.motions[:2]
    )
    return grasped, slid


@pytest.mark.parametrize("rail", [None, 0.12])
def test_a_rack_is_pulled_out_as_far_as_its_rail_goes(rail: float | None) -> None:
    """The scene may say how far a rack's rail lets it out (the rack fixture's ``rail``: the physics
    world's racks slide 12 cm); without it, the family's ``RACK_TRAVEL`` (16 cm)."""
    franka = driver()
    handle = Vector3(x=0.67, y=0.0, z=0.30)  # the top rack pushed in
    franka.toggle_tray(top_rack(handle, False, rail=rail))  # pull it out
    grasped, slid = _grasped_and_slid()
    assert np.allclose(slid - grasped, [-(rail or 0.16), 0.0, 0.0], atol=0.005)


class SlowRobot(FakeRobot):
    """A motion that takes until ``stop`` halts it, as franky's blocking ``move`` does."""

    def __init__(self, address: str, **options: object) -> None:
        super().__init__(address, **options)
        self.halted = threading.Event()
        self.moving = threading.Event()

    def move(self, motion: object) -> None:
        self.moving.set()
        if not self.halted.wait(timeout=10.0):
            raise AssertionError("the motion was never halted")
        self.calls.append("halted")
        raise RuntimeError("franky: motion aborted by stop")  # as libfranka reports it

    def stop(self) -> None:
        super().stop()
        self.halted.set()


def test_an_abort_halts_the_motion_under_way_which_fails_with_its_reason() -> None:
    config = FrankaConfig(address="172.16.0.2", realtime=False)
    franka = FrankaDriver(config=config, robot_class=SlowRobot, gripper_class=FakeGripper)
    outcome: dict[str, object] = {}

    def pick() -> None:
        try:
            franka.pick(Motion("e:0", "block_0", BLOCK, Quaternion()))
        except SkillError as exc:
            outcome["reason"] = exc.reason

    worker = threading.Thread(target=pick)
    worker.start()
    robot = SlowRobot.last
    assert isinstance(robot, SlowRobot) and robot.moving.wait(timeout=10.0)
    franka.abort("sim_lost")
    worker.join(timeout=10.0)
    assert outcome == {"reason": "sim_lost"}  # not a robot_error: the cause is named
    assert "stop" in robot.calls
