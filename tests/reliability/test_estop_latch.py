"""The emergency stop is a latch held by the stack: it outlives kill -9 of any service, of the
router and of a whole ``manigraph up``; nothing moves until ``manigraph resume``."""

from __future__ import annotations

import json
import signal
import socket
import subprocess
import sys
import time

import pytest
from reliability_helpers import STARTUP, Inbox, action, reset, start

from manigraph_shared.errors import RequestRefused
from manigraph_shared.messages import (
    JointTrajectoryCommand,
    RobotCommand,
    Scene,
    SkillState,
    SkillStatus,
)
from manigraph_testkit.testing import Stack, free_port

pytestmark = pytest.mark.integration

SERVICES = ("sim", "skills", "planner")


def forged_action(decision_id: str) -> object:
    scene = Scene.from_builtins(
        {"episode_id": "forged", "sequence": 1, "objects": [], "goals": [], "stamp": time.time()}
    )
    return action(scene, "block_0", "goal_0", decision_id, policy="other-decider")


def restart(stack: Stack, *names: str) -> None:
    """kill -9 ``names``, then start them again as they were (the router first)."""
    for name in names:
        stack.stop(name, signal.SIGKILL)
    for name in sorted(names, key=lambda n: n != "router"):
        stack.start(name) if name == "router" else stack.start(name, name)


def test_a_stop_outlives_kill_9_of_every_service_and_the_router(running_stack: Stack) -> None:
    start(running_stack, *SERVICES)
    with running_stack.client() as bus:
        running_stack.wait_alive(bus, *SERVICES, timeout=STARTUP)
        stopped = running_stack.run("stop", "--reason", "latch test", timeout=30)
        assert stopped.returncode == 0, stopped.stderr
    for victims in (("sim", "skills"), ("planner", "sim", "skills", "router")):
        restart(running_stack, *victims)
        with running_stack.client() as bus:
            moved = Inbox(bus, RobotCommand), Inbox(bus, JointTrajectoryCommand)
            skill = Inbox(bus, SkillStatus)
            running_stack.wait_alive(bus, *SERVICES, timeout=STARTUP)
            time.sleep(0.3)
            with pytest.raises(RequestRefused, match="estop_engaged: latch test"):
                reset(bus, f"after-{len(victims)}")
            decision = f"forged:{len(victims)}"
            bus.publish(forged_action(decision))  # type: ignore[arg-type]
            refused = skill.wait(
                lambda s, decision=decision: s.decision_id == decision and s.state.terminal
            )
            assert (refused.state, refused.reason) == (SkillState.FAILED, "stopped")
            time.sleep(0.5)
            assert moved[0].seen == [] and moved[1].seen == []

    report = json.loads(running_stack.run("status", "--json", timeout=60).stdout.splitlines()[-1])
    assert report["estop_engaged"] is True
    assert report["estop_latch"]["default"]["reason"] == "latch test"
    views = {s["service"]: s.get("estop") for s in report["services"]}
    assert all(views[name] == {"engaged": True, "known": True} for name in SERVICES), views
    assert not [w for w in report["warnings"] if "emergency stop" in w], report["warnings"]

    resumed = running_stack.run("resume", timeout=30)
    assert resumed.returncode == 0, resumed.stderr
    with running_stack.client() as bus:
        reset(bus, "after-resume")  # accepted


def test_a_whole_up_started_again_on_the_same_stack_comes_back_stopped(
    running_stack: Stack,
) -> None:
    port = free_port()
    env = {**running_stack.env, "MANIGRAPH_ZENOH_CONNECT": f"tcp/127.0.0.1:{port}"}

    def up(*extra: str) -> subprocess.Popen[str]:
        command = [sys.executable, "-m", "manigraph_shared.cli", "up", "--port", str(port)]
        return subprocess.Popen(
            [*command, "--task", "stack", "--blocks", "3", *extra],
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            text=True,
            env=env,
        )

    first = up()  # no --episodes: the stack keeps running
    try:
        deadline = time.monotonic() + STARTUP
        while True:
            stop = subprocess.run(
                [sys.executable, "-m", "manigraph_shared.cli", "stop", "--port", str(port)],
                capture_output=True,
                text=True,
                env=env,
                timeout=60,
            )
            if stop.returncode == 0 or time.monotonic() > deadline:
                break
            time.sleep(1.0)
        assert stop.returncode == 0, stop.stderr
    finally:
        first.send_signal(signal.SIGKILL)  # the whole stack dies (its children follow it)
        first.communicate(timeout=60)
    # Its children follow it (parent-death signal); the router may take its 5 s stop grace.
    deadline = time.monotonic() + 30
    while time.monotonic() < deadline:
        with socket.socket() as probe:
            if probe.connect_ex(("127.0.0.1", port)) != 0:
                break
        time.sleep(0.2)

    again = up("--episodes", "1")
    _, err = again.communicate(timeout=STARTUP + 60)
    assert again.returncode != 0, err[-3000:]
    assert "estop_engaged: manigraph stop" in err.splitlines()[-1], err[-2000:]
    assert "0/0 goals, 0 steps" in err
