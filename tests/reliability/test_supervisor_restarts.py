"""``manigraph up`` keeps its stack up: a dead service comes back, a dead router stops it."""

from __future__ import annotations

import io
import os
import signal
import subprocess
import sys
import time
from dataclasses import dataclass
from pathlib import Path

import pytest

from manigraph_shared.errors import CONFIG_EXIT_CODE, RUNTIME_EXIT_CODE
from manigraph_testkit.testing import free_port
from manigraph_tools.supervisor import ProcessSpec, RestartPolicy, Supervisor


@dataclass(frozen=True)
class ScriptSpec(ProcessSpec):
    """A child that runs a Python snippet instead of a manigraph command."""

    def argv(self) -> list[str]:
        return [sys.executable, "-c", *self.args]


def _run_until_failure(supervisor: Supervisor, seconds: float) -> str | None:
    deadline = time.monotonic() + seconds
    while time.monotonic() < deadline:
        if (failure := supervisor.poll()) is not None:
            return failure
        time.sleep(0.02)
    return None


def test_a_crashing_service_is_restarted_with_back_off_then_given_up_on() -> None:
    output = io.StringIO()
    policy = RestartPolicy(first_delay=0.05, max_delay=0.2, max_restarts=3, stable_after=60)
    supervisor = Supervisor(output=output, policy=policy)
    supervisor.start(ScriptSpec("sleeper", ["import time; time.sleep(60)"]))
    supervisor.start(ScriptSpec("crasher", ["raise SystemExit(3)"]))
    try:
        failure = _run_until_failure(supervisor, 20)
    finally:
        supervisor.stop(grace=2)
    assert failure is not None and "crasher exited with code 3 after 3 restarts" in failure
    assert supervisor.restarts == {"sleeper": 0, "crasher": 3}
    log = output.getvalue()
    delays = [
        line.split("restarting in ")[1].split(" s")[0]
        for line in log.splitlines()
        if "crasher exited" in line and "restarting in" in line
    ]
    assert delays == ["0.1", "0.1", "0.2"]  # 0.05, 0.1, 0.2 doubled and capped at 0.2
    assert log.count("restarted crasher") == 3


def test_a_service_refusing_its_configuration_is_not_restarted() -> None:
    output = io.StringIO()
    policy = RestartPolicy(first_delay=0.05, max_delay=0.2, max_restarts=3, stable_after=60)
    supervisor = Supervisor(output=output, policy=policy)
    supervisor.start(ScriptSpec("sleeper", ["import time; time.sleep(60)"]))
    supervisor.start(ScriptSpec("refuser", [f"raise SystemExit({CONFIG_EXIT_CODE})"]))
    try:
        failure = _run_until_failure(supervisor, 20)
    finally:
        supervisor.stop(grace=2)
    assert failure == "refuser refused its configuration (see its log above); not restarted"
    assert supervisor.restarts == {"sleeper": 0, "refuser": 0}
    assert "restarted refuser" not in output.getvalue()


def test_stopping_a_stack_stops_its_services_together_and_the_router_last() -> None:
    """Each child takes 0.5 s to stop; one by one, the three would take 1.5 s."""
    slow_stop = (
        "import signal, sys, time\n"
        "def stop(*_):\n"
        "    time.sleep(0.5); print('stopped', time.monotonic(), flush=True); sys.exit(0)\n"
        "signal.signal(signal.SIGTERM, stop)\n"
        "print('ready', flush=True)\n"
        "time.sleep(60)\n"
    )
    output = io.StringIO()
    supervisor = Supervisor(output=output)
    for name in ("router", "sim", "planner"):
        supervisor.start(ScriptSpec(name, [slow_stop]))
    deadline = time.monotonic() + 30
    while output.getvalue().count("ready") < 3 and time.monotonic() < deadline:
        time.sleep(0.05)
    supervisor.stop(grace=5)
    stopped = {
        line.split("|")[0].strip(): float(line.split()[-1])
        for line in output.getvalue().splitlines()
        if "stopped" in line
    }
    assert set(stopped) == {"router", "sim", "planner"}, output.getvalue()
    assert abs(stopped["sim"] - stopped["planner"]) < 0.4  # together, not 0.5 s apart
    assert stopped["router"] - max(stopped["sim"], stopped["planner"]) > 0.4  # after them


def test_the_router_dying_stops_the_stack_with_its_name() -> None:
    supervisor = Supervisor(output=io.StringIO())
    supervisor.start(ScriptSpec("router", ["raise SystemExit(1)"]))
    try:
        failure = _run_until_failure(supervisor, 10)
    finally:
        supervisor.stop(grace=2)
    assert failure == "router exited with code 1; the stack cannot run without it"
    assert supervisor.restarts == {"router": 0}


def _child_pid(parent: int, command: str) -> int:
    for entry in Path("/proc").iterdir():
        if not entry.name.isdigit():
            continue
        try:
            stat = (entry / "stat").read_text()
            cmdline = (entry / "cmdline").read_bytes().split(b"\0")
        except OSError:
            continue
        ppid = int(stat.rsplit(")", 1)[1].split()[1])
        if ppid == parent and command.encode() in cmdline:
            return int(entry.name)
    raise AssertionError(f"no child '{command}' of {parent}")


def _wait_for(path: Path, text: str, seconds: float) -> None:
    deadline = time.monotonic() + seconds
    while time.monotonic() < deadline:
        if path.exists() and text in path.read_text(errors="replace"):
            return
        time.sleep(0.2)
    raise AssertionError(f"'{text}' not in {path}:\n{path.read_text(errors='replace')[-3000:]}")


@pytest.mark.integration
def test_up_restarts_a_killed_service_and_the_stack_still_runs_episodes(tmp_path: Path) -> None:
    port = free_port()
    out = tmp_path / "up.out"
    with out.open("w") as sink:
        up = subprocess.Popen(
            [sys.executable, "-m", "manigraph_shared.cli", "up", "--port", str(port)],
            stdout=sink,
            stderr=subprocess.STDOUT,
            env={**os.environ, "PYTHONUNBUFFERED": "1"},
        )
    try:
        _wait_for(out, "stack is up", 120)
        os.kill(_child_pid(up.pid, "skills"), signal.SIGKILL)
        _wait_for(out, "skills exited with code -9; restarting in 0.5 s (1/5 in a row)", 10)
        _wait_for(out, "restarted skills (restart 1", 10)
        env = {
            **os.environ,
            "MANIGRAPH_ZENOH_CONNECT": f"tcp/127.0.0.1:{port}",
            "MANIGRAPH_ZENOH_NO_MULTICAST_SCOUTING": "1",
        }
        run = subprocess.run(
            [sys.executable, "-m", "manigraph_shared.cli", "run", "--blocks", "3", "--json"],
            capture_output=True,
            text=True,
            env=env,
            timeout=120,
            check=False,
        )
        assert run.returncode == 0, run.stderr[-2000:]
        assert '"success_rate": 1.0' in run.stdout
        assert up.poll() is None  # the stack never stopped

        os.kill(_child_pid(up.pid, "router"), signal.SIGKILL)
        assert up.wait(timeout=30) == RUNTIME_EXIT_CODE
        text = out.read_text()
        assert "the stack stopped: router exited with code -9" in text
    finally:
        if up.poll() is None:
            up.send_signal(signal.SIGINT)
            up.wait(timeout=30)
