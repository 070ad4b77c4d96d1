"""`manigraph up` as a user runs it: the whole stack, then Ctrl-C."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time

import pytest

from manigraph_shared.testing import free_port

pytestmark = pytest.mark.integration


def children_of(pid: int) -> list[int]:
    result = subprocess.run(
        ["ps", "-o", "pid=", "--ppid", str(pid)], capture_output=True, text=True
    )
    return [int(p) for p in result.stdout.split()]


def ignore_sigint() -> None:
    """Start as a background job of a script does: with SIGINT ignored."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)


@pytest.mark.parametrize("stop_signal", [signal.SIGINT, signal.SIGTERM])
def test_ctrl_c_stops_every_service_cleanly(stop_signal: int) -> None:
    up = subprocess.Popen(
        [sys.executable, "-m", "manigraph_shared.cli", "up", "--port", str(free_port())],
        stdout=subprocess.PIPE,
        stderr=subprocess.STDOUT,
        text=True,
        preexec_fn=ignore_sigint,
    )
    assert up.stdout is not None
    lines = []
    deadline = time.monotonic() + 60
    for line in up.stdout:
        lines.append(line)
        if "stack is up" in line or time.monotonic() > deadline:
            break
    assert any("stack is up: router, sim, planner, skills" in line for line in lines), lines
    children = children_of(up.pid)
    assert len(children) == 4
    up.send_signal(stop_signal)
    rest, _ = up.communicate(timeout=30)
    assert up.returncode == 0
    for name in ("sim", "planner", "skills", "router"):
        assert f"{name:>10} | " in rest and "stopping" in rest
    for pid in children:
        with pytest.raises(ProcessLookupError):
            os.kill(pid, 0)
