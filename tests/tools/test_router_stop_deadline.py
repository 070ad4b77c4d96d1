"""A router whose stop hangs is still ended: the kernel's SIGALRM, armed at the stop request,
needs no Python thread to run (a close stuck in native code holding the GIL stops them all).

The bug this guards: ``up`` killed in the middle of its stop left its router on the port for
over a minute (CI, SIGINT then SIGKILL of ``up``)."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time

import pytest

from manigraph_testkit.testing import free_port
from manigraph_tools.zenoh_router import HARD_STOP_S

pytestmark = pytest.mark.integration

# The latch's close never returns: the stop hangs before the old STOP_GRACE timer is started.
HANGING_ROUTER = """
import sys, time
from manigraph_tools import estop_keeper
estop_keeper.EstopKeeper.close = lambda self: time.sleep(3600)
from manigraph_shared.cli import main
sys.exit(main(["router", "--listen", sys.argv[1]]))
"""


def test_a_router_whose_stop_hangs_is_ended_by_the_hard_deadline(tmp_path) -> None:
    port = free_port()
    router = subprocess.Popen(
        [sys.executable, "-c", HANGING_ROUTER, f"tcp/127.0.0.1:{port}"],
        stdout=subprocess.PIPE,
        stderr=subprocess.STDOUT,
        env={**os.environ, "MANIGRAPH_STATE_DIR": str(tmp_path), "PYTHONUNBUFFERED": "1"},
    )
    try:
        assert router.stdout is not None
        seen = b""
        deadline = time.monotonic() + 60
        while b"listening" not in seen:
            assert time.monotonic() < deadline and router.poll() is None, seen.decode()
            seen += router.stdout.readline()
        router.send_signal(signal.SIGTERM)
        started = time.monotonic()
        code = router.wait(timeout=HARD_STOP_S + 30)
        took = time.monotonic() - started
        assert code == -signal.SIGALRM, (code, router.stdout.read().decode())
        assert took >= HARD_STOP_S - 1  # it was the deadline, not the stop, that ended it
    finally:
        router.kill()
        router.wait()
