"""The camera's warm-up says how far it is: progress lines while the renderer compiles its
shaders (which holds the GIL, so no thread of the sim could say it), then how long it took."""

from __future__ import annotations

import logging
import re
import time

import pytest

from manigraph_sim.physics import warm_up
from manigraph_sim.physics.video import vulkan_available

log = logging.getLogger("manigraph.sim")


def test_progress_lines_come_while_a_block_runs_and_stop_with_it(
    caplog: pytest.LogCaptureFixture, capfd: pytest.CaptureFixture[str]
) -> None:
    caplog.set_level(logging.INFO, "manigraph.sim")
    with warm_up.progress_while(log, "camera: warming up", "a while", every=0.2):
        time.sleep(1.1)
    lines = [line for line in capfd.readouterr().err.splitlines() if "so far" in line]
    time.sleep(1.0)  # a ticker still running would write again (a loaded machine: no bound)
    later = [line for line in capfd.readouterr().err.splitlines() if "so far" in line]
    assert lines and not later, (lines, later)
    assert re.search(r"INFO  manigraph\.sim: camera: warming up: \d+ s so far$", lines[0])
    said = [r.getMessage() for r in caplog.records]
    assert said[0] == "camera: warming up (a while) ..."
    assert re.match(r"camera: warming up: done in \d+\.\d s", said[-1]), said[-1]


def test_no_progress_lines_where_the_log_says_nothing_at_info(
    capfd: pytest.CaptureFixture[str],
) -> None:
    quiet = logging.getLogger("manigraph.quiet-test")
    quiet.setLevel(logging.WARNING)
    with warm_up.progress_while(quiet, "camera: warming up", "a while", every=0.1):
        time.sleep(0.4)
    assert "so far" not in capfd.readouterr().err


@pytest.mark.skipif(not vulkan_available(), reason="needs a Vulkan device (install-vulkan.sh)")
def test_the_physics_camera_warm_up_reports_progress_while_shaders_compile(
    caplog: pytest.LogCaptureFixture,
    capfd: pytest.CaptureFixture[str],
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    from manigraph_sim.physics.backend import PhysicsBackend
    from manigraph_sim.physics.camera import CameraConfig

    monkeypatch.setattr(warm_up, "PROGRESS_EVERY", 1.0)
    caplog.set_level(logging.INFO, "manigraph.sim")
    started = time.monotonic()
    PhysicsBackend(camera=CameraConfig(format="png"))
    seconds = time.monotonic() - started
    ticks = [line for line in capfd.readouterr().err.splitlines() if "so far" in line]
    said = [r.getMessage() for r in caplog.records if r.name == "manigraph.sim"]
    assert said[0].startswith("camera: warming up the renderer (")
    assert said[-1].startswith("camera: warming up the renderer: done in ")
    # Lines while the shaders hold the GIL: one a second when the machine is free, and at
    # least one every 5 s when it is loaded (the ticker is a process of its own).
    assert len(ticks) >= int(seconds / 5), (seconds, ticks)
