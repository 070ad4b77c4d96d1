"""The emergency stop: refused while engaged, accepted after resume, logged to MCAP."""

from __future__ import annotations

import time
from pathlib import Path

import pytest
from reliability_helpers import (
    STARTUP,
    Inbox,
    action,
    rejections,
    reset,
    scene_of,
    start,
    top_block_and_free_goal,
)

from manigraph_shared.mcap_log import read_log
from manigraph_shared.messages import (
    EmergencyStop,
    Scene,
    ServiceStatus,
    SkillState,
    SkillStatus,
)
from manigraph_tools.testing import Stack

pytestmark = pytest.mark.integration


def test_actions_are_refused_while_stopped_and_accepted_after_resume(
    running_stack: Stack, tmp_path: Path
) -> None:
    log = tmp_path / "estop.mcap"
    start(running_stack, "sim", "skills")
    running_stack.start("recorder", "record", "--output", str(log))
    with running_stack.client() as bus:
        running_stack.wait_alive(bus, "sim", "skills", "recorder", timeout=STARTUP)
        scenes, skill = Inbox(bus, Scene), Inbox(bus, SkillStatus)
        statuses = Inbox(bus, ServiceStatus)
        time.sleep(0.3)
        reset(bus, "estop")
        real = scene_of(scenes, "estop")
        block, goal = top_block_and_free_goal(real)

        stopped = running_stack.run("stop", "--reason", "test", timeout=30)
        assert stopped.returncode == 0, stopped.stderr  # skills acknowledged it
        bus.publish(action(real, block, goal, "estop:0"))
        refused = skill.wait(lambda s: s.decision_id == "estop:0" and s.state.terminal)
        assert refused.state is SkillState.FAILED and refused.reason == "stopped"
        assert rejections(statuses, "skills", "Action:stopped") == 1

        resumed = running_stack.run("resume", timeout=30)
        assert resumed.returncode == 0, resumed.stderr
        bus.publish(action(real, block, goal, "estop:1"))
        done = skill.wait(lambda s: s.decision_id == "estop:1" and s.state.terminal)
        assert done.state is SkillState.SUCCEEDED, done
        time.sleep(0.5)  # the recorder flushes every 100 ms
    running_stack.stop("recorder")
    logged = [EmergencyStop.decode(m.data) for m in read_log(log, [EmergencyStop.key])]
    assert [(m.engaged, m.reason) for m in logged] == [(True, "test"), (False, "manigraph resume")]
