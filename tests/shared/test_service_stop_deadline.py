"""A service whose stop hangs is still ended: SIGALRM, armed when the stop is asked for, needs
no Python thread to run (a close blocked in native code holding the GIL stops them all).

The bug this guards: ``up`` killed with SIGKILL right after "stack is up" left one of its
services alive past the test's minute (CI, 2026-12-08), its parent-death SIGTERM received."""

from __future__ import annotations

import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from manigraph_shared.service import HARD_STOP_S
from manigraph_testkit.testing import Stack, free_port

pytestmark = pytest.mark.integration

# The sim service, with a bus whose close never returns.
HANGING_SIM = """
import sys, time
from manigraph_shared import bus
bus.Bus.close = lambda self: time.sleep(3600)
from manigraph_shared.cli import main
sys.exit(main(["sim", "--backend", "geometric"]))
"""


def test_a_service_whose_stop_hangs_is_ended_by_the_hard_deadline(tmp_path: Path) -> None:
    stack = Stack(free_port(), tmp_path)
    router = stack.start("router")
    sim_log = tmp_path / "sim.log"
    with sim_log.open("wb") as sink:
        sim = subprocess.Popen(
            [sys.executable, "-c", HANGING_SIM],
            stdout=sink,
            stderr=subprocess.STDOUT,
            env=stack.env,
        )
    try:
        deadline = time.monotonic() + 180
        while b"ready" not in sim_log.read_bytes():
            assert sim.poll() is None and time.monotonic() < deadline, sim_log.read_text()
            time.sleep(0.1)
        sim.send_signal(signal.SIGTERM)
        asked = time.monotonic()
        code = sim.wait(timeout=HARD_STOP_S + 60)
        took = time.monotonic() - asked
        assert code == -signal.SIGALRM, (code, sim_log.read_text()[-2000:])
        assert took >= HARD_STOP_S - 1  # the deadline ended it, not the stop
        assert b"received SIGTERM, stopping" in sim_log.read_bytes()
    finally:
        for process in (sim, router):
            process.kill()
            process.wait()
