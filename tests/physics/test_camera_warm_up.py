"""The camera's warm-up says how far it is: progress lines while the renderer compiles its
shaders (which holds the GIL, so no thread of the sim could say it), then how long it took."""

from __future__ import annotations

import logging
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
    time.sleep(0.5)  # a ticker still running would write again
    lines = [line for line in capfd.readouterr().err.splitlines() if "so far" in line]
    assert 3 <= len(lines) <= 6, lines
    assert lines[0].endswith("INFO  manigraph.sim: camera: warming up: 0 s so far")
    said = [r.getMessage() for r in caplog.records]
    assert said[0] == "camera: warming up (a while) ..."
    assert said[-1].startswith("camera: warming up: done in 1.")


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
    # One line a second (the first at 1 s), however long the shaders held the GIL.
    assert len(ticks) >= int(seconds) - 3, (seconds, ticks)
