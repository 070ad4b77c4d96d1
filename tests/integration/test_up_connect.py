"""`manigraph up` prints the line a client needs, and that line, run as printed, reaches it."""

from __future__ import annotations

import os
import shlex
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from manigraph_testkit.testing import free_port

pytestmark = pytest.mark.integration

CLI = [sys.executable, "-m", "manigraph_shared.cli"]


def _wait_for_line(log: Path, up: subprocess.Popen[bytes], prefix: str) -> str:
    deadline = time.monotonic() + 180  # four imports of torch on a loaded machine
    while True:
        for line in log.read_text(errors="replace").splitlines():
            if line.startswith(prefix):
                return line
        assert up.poll() is None, log.read_text(errors="replace")[-3000:]
        assert time.monotonic() < deadline, log.read_text(errors="replace")[-3000:]
        time.sleep(0.05)


@pytest.mark.parametrize("secure", [False, True], ids=["plain", "secure"])
def test_the_printed_connect_line_reaches_the_stack(tmp_path: Path, secure: bool) -> None:
    port = free_port()
    log = tmp_path / "up.log"
    argv = [*CLI, "up", "--port", str(port), *(["--secure"] if secure else [])]
    with log.open("wb") as sink:
        up = subprocess.Popen(argv, stdout=sink, stderr=subprocess.STDOUT)
    try:
        clients = _wait_for_line(log, up, "clients: ")
        scheme = "tls" if secure else "tcp"
        assert f" -e {scheme}/127.0.0.1:{port}" in clients
        command = shlex.split(clients.removeprefix("clients: "))
        assert command[:2] == ["manigraph", "doctor"]
        # as a user runs it: none of up's environment, only the printed flags
        env = {k: v for k, v in os.environ.items() if not k.startswith("MANIGRAPH_")}
        doctor = subprocess.run(
            [*CLI, *command[1:]], capture_output=True, text=True, env=env, timeout=120
        )
        # doctor exits 1 if any of router, sim, planner, skills is missing
        assert doctor.returncode == 0, doctor.stdout + doctor.stderr
        text = log.read_text()
        for step in ("status", "run", "stop", "view", "explain"):
            assert f"  manigraph {step}" in text
        if secure:
            certificates = Path(_wait_for_line(log, up, "certificates: ").split()[1])
            assert (certificates / "ca.pem").is_file()
            assert f"--tls-dir {certificates} --tls-identity client" in clients
    finally:
        up.send_signal(signal.SIGINT)
        up.wait(timeout=60)
    if secure:
        assert not certificates.exists()  # made for the run, gone with it
