"""Helpers for tests that run real manigraph processes on loopback.

No mocks: a test starts the router and services as real processes on a free port with
multicast scouting off, talks to them over a real Zenoh session, and stops them at the end.
"""

from __future__ import annotations

import contextlib
import json
import os
import signal
import socket
import subprocess
import sys
import tempfile
import threading
import time
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path

import zenoh

from manigraph_shared.bus import Bus
from manigraph_shared.bus_config import BusConfig
from manigraph_shared.messages import Action


def cpu_share(seconds: float = 0.5) -> float:
    """The share of one core a busy thread of this process gets now (1.0: a whole core)."""
    wall_start, cpu_start = time.perf_counter(), time.thread_time()
    while time.perf_counter() - wall_start < seconds:
        pass
    return (time.thread_time() - cpu_start) / (time.perf_counter() - wall_start)


def spare_core_problem(need: float = 0.9, seconds: float = 0.5) -> str | None:
    """Why a test that needs about one free core (a real-time loop) cannot have it here, or
    None. Measured, not guessed from the load average: with ``sched_autogroup`` a busy
    process in another session takes less than its load suggests, or more."""
    share = cpu_share(seconds)
    if share >= need:
        return None
    load = os.getloadavg()[0]
    return (
        f"needs {need:.0%} of a free core for its real-time loop; a busy thread got {share:.0%} "
        f"(load {load:.1f} on {os.cpu_count()} cores)"
    )


def free_port() -> int:
    with socket.socket() as sock:
        sock.bind(("127.0.0.1", 0))
        return int(sock.getsockname()[1])


class Stack:
    """Processes of one test stack sharing one router endpoint.

    With ``tls_dir`` (certificates of ``manigraph certs``) the stack runs with mutual TLS and
    the router's access control; each process presents the identity it is started with.
    """

    def __init__(self, port: int, log_dir: Path, tls_dir: Path | None = None) -> None:
        self.port = port
        self.tls_dir = tls_dir
        self.endpoint = f"{'tls' if tls_dir else 'tcp'}/127.0.0.1:{port}"
        self.log_dir = log_dir
        self.processes: dict[str, subprocess.Popen[bytes]] = {}

    @property
    def env(self) -> dict[str, str]:
        return {
            **os.environ,
            "MANIGRAPH_ZENOH_MODE": "client",
            "MANIGRAPH_ZENOH_CONNECT": self.endpoint,
            "MANIGRAPH_ZENOH_NO_MULTICAST_SCOUTING": "1",
            "MANIGRAPH_TLS_DIR": str(self.tls_dir or ""),
            "MANIGRAPH_TLS_IDENTITY": "",
            # The stack's own emergency-stop latch: a stop one test leaves engaged must not
            # reach another test's stack on a reused port.
            "MANIGRAPH_STATE_DIR": str(self.log_dir / "state"),
            "PYTHONUNBUFFERED": "1",
        }

    def env_as(self, identity: str) -> dict[str, str]:
        """The environment of a process presenting ``identity`` (ignored without TLS)."""
        return {**self.env, "MANIGRAPH_TLS_IDENTITY": identity if self.tls_dir else ""}

    def start(self, name: str, *args: str, identity: str | None = None) -> subprocess.Popen[bytes]:
        """Start ``manigraph ARGS`` as ``name``; with TLS it presents ``identity`` (or ``name``)."""
        if name == "router" and not args:
            args = ("router", "--listen", self.endpoint)
        log = (self.log_dir / f"{name}.log").open("ab")
        process = subprocess.Popen(
            [sys.executable, "-m", "manigraph_shared.cli", *args],
            stdout=log,
            stderr=subprocess.STDOUT,
            stdin=subprocess.DEVNULL,
            env=self.env_as(identity or name),
        )
        self.processes[name] = process
        return process

    def run(
        self, *args: str, timeout: float = 120.0, identity: str = "client"
    ) -> subprocess.CompletedProcess[str]:
        """Run one manigraph command to completion against this stack; once its router,
        if this stack started one, listens (a one-shot client says at once that nobody does,
        and a router on a loaded machine has taken 30-90 s to start)."""
        if "router" in self.processes:
            self.wait_listening(timeout=180.0)
        return subprocess.run(
            [sys.executable, "-m", "manigraph_shared.cli", *args],
            capture_output=True,
            text=True,
            env=self.env_as(identity),
            timeout=timeout,
            check=False,
        )

    def wait_listening(self, timeout: float = 180.0) -> None:
        """Return once something accepts connections on this stack's port; raise if the
        router exits first or ``timeout`` passes."""
        deadline = time.monotonic() + timeout
        while True:
            with contextlib.suppress(OSError):
                socket.create_connection(("127.0.0.1", self.port), timeout=1.0).close()
                return
            router = self.processes.get("router")
            if router is not None and router.poll() is not None:
                raise AssertionError(f"router exited ({router.returncode}):\n{self.log('router')}")
            if time.monotonic() > deadline:
                raise AssertionError(f"nothing listens on {self.endpoint} after {timeout:.0f} s")
            time.sleep(0.05)

    def log(self, name: str) -> str:
        path = self.log_dir / f"{name}.log"
        return path.read_text(errors="replace") if path.exists() else ""

    def stop(self, name: str, sig: int = signal.SIGTERM, timeout: float = 10.0) -> int:
        process = self.processes.pop(name)
        if process.poll() is None:
            process.send_signal(sig)
            try:
                process.wait(timeout=timeout)
            except subprocess.TimeoutExpired:
                process.kill()
                process.wait()
        return int(process.returncode)

    def stop_all(self) -> None:
        for name in reversed(list(self.processes)):
            self.stop(name)

    def bus_config(self, identity: str = "client", wait_seconds: float = 60.0) -> BusConfig:
        return BusConfig(
            connect=(self.endpoint,),
            wait_seconds=wait_seconds,
            tls_dir=self.tls_dir,
            tls_identity=identity if self.tls_dir else None,
        )

    @contextmanager
    def client(self, wait_seconds: float = 60.0, identity: str = "client") -> Iterator[Bus]:
        bus = Bus.open(self.bus_config(identity, wait_seconds))
        try:
            yield bus
        finally:
            bus.close()

    # Generous waits: on a loaded 2-core machine the planner's torch import alone has taken
    # 40-60 s; a service that never comes up still fails the test, only later.
    def wait_alive(self, bus: Bus, *names: str, timeout: float = 90.0) -> set[str]:
        deadline = time.monotonic() + timeout
        while True:
            alive = bus.alive_services(timeout=1.0)
            if set(names) <= alive:
                return alive
            for name, process in self.processes.items():
                if process.poll() is not None:
                    raise AssertionError(f"{name} exited ({process.returncode}):\n{self.log(name)}")
            if time.monotonic() > deadline:
                raise AssertionError(f"not alive after {timeout} s: {set(names) - alive}")
            time.sleep(0.1)


@contextmanager
def stack(log_dir: Path, tls_dir: Path | None = None) -> Iterator[Stack]:
    running = Stack(free_port(), log_dir, tls_dir)
    try:
        yield running
    finally:
        running.stop_all()


@dataclass(frozen=True)
class KilledRecording:
    """What ``record_then_kill`` left: the unfinished log, when each step was published
    (monotonic seconds, by the Action's ``scene_sequence``) and when the recorder was killed."""

    log: Path
    published: dict[int, float]
    killed_at: float

    def lost_window_ms(self, kept: set[int]) -> float:
        """How far back before the kill published steps are missing from ``kept``, in ms."""
        lost = [
            at for step, at in self.published.items() if at < self.killed_at and step not in kept
        ]
        return 1000 * (self.killed_at - min(lost)) if lost else 0.0

    def flushed_before(self, margin: float) -> set[int]:
        """Steps published more than ``margin`` seconds before the kill."""
        return {step for step, at in self.published.items() if at < self.killed_at - margin}


def record_then_kill(running: Stack, log: Path, seconds: float = 1.5) -> KilledRecording:
    """Start a router and a recorder writing ``log``, publish Actions at ~500/s for
    ``seconds``, then SIGKILL the recorder mid-stream: no chance to finish its file."""
    running.start("router")
    recorder = running.start("recorder", "record", "--output", str(log))
    published: dict[int, float] = {}
    with running.client() as bus:
        running.wait_alive(bus, "recorder")
        stop = threading.Event()

        def publish() -> None:
            step = 0
            while not stop.is_set():
                published[step] = time.monotonic()
                bus.publish(
                    Action(
                        decision_id=f"e:{step}",
                        episode_id="e",
                        scene_sequence=step,
                        object_id="b",
                        goal_id="g",
                        policy="load",
                        stamp=time.time(),
                    )
                )
                step += 1
                time.sleep(0.002)

        publisher = threading.Thread(target=publish)
        publisher.start()
        time.sleep(seconds)
        killed_at = time.monotonic()
        recorder.kill()
        recorder.wait()
        stop.set()
        publisher.join()
    return KilledRecording(log, published, killed_at)


def open_raw_session(endpoint: str, **tls: str) -> zenoh.Session:
    """A bare Zenoh client of ``endpoint`` (one attempt, 1.5 s), with the raw ``tls`` keys of
    ``transport/link/tls`` given, and without the checks of ``BusConfig``: what an intruder
    would open. Raises ``zenoh.ZError`` when the router refuses it."""
    config = zenoh.Config()
    config.insert_json5("mode", '"client"')
    config.insert_json5("connect/endpoints", json.dumps([endpoint]))
    config.insert_json5("scouting/multicast/enabled", "false")
    config.insert_json5("connect/timeout_ms", "1500")
    config.insert_json5("connect/exit_on_failure", "true")
    for key, value in tls.items():
        config.insert_json5(f"transport/link/tls/{key}", json.dumps(value))
    return zenoh.open(config)


def run_up(
    *args: str,
    timeout: float = 180.0,
    check: bool = True,
    env: dict[str, str] | None = None,
) -> subprocess.CompletedProcess[str]:
    """``manigraph up ARGS`` on a free port, to completion, with ``env`` over this process's
    environment (and a state directory of its own unless ``env`` names one); with ``check``
    it fails loudly if ``up`` fails."""
    with tempfile.TemporaryDirectory(prefix="manigraph-state-") as state:
        result = subprocess.run(
            [
                sys.executable,
                "-m",
                "manigraph_shared.cli",
                "up",
                *args,
                "--port",
                str(free_port()),
            ],
            capture_output=True,
            text=True,
            timeout=timeout,
            check=False,
            env={**os.environ, "MANIGRAPH_STATE_DIR": state, **(env or {})},
        )
    if check and result.returncode != 0:
        raise AssertionError(f"manigraph up {' '.join(args)} failed:\n{result.stderr[-3000:]}")
    return result
