"""``manigraph up``: the router and every service of a stack as local child processes.

Each child's output is prefixed with its name (and copied to ``<log_dir>/<name>.log``); the
services are stopped together with SIGTERM, then the recorder and the router; SIGKILL follows
for any that outlive a grace period.

A service that dies is started again (``watch``) after a back-off that doubles from
``RestartPolicy.first_delay`` up to ``max_delay``; a child that then stays up for
``stable_after`` seconds has its back-off reset. Every restart is counted and logged; a child
that dies ``max_restarts`` times in a row (without a stable run between) gives up, and that
stops the stack with its name. The **router** is not restarted: every other process, and
``up``'s own episode client, reaches the others only through it, so while it is down nothing
can run and a new router would have to be found again by every session; its death stops the
stack, naming it, instead of leaving the stack half-connected. Nor is a service that exits
with ``CONFIG_EXIT_CODE``: it refused its options or the machine (no Vulkan device, say), and
the same start would fail the same way.
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import threading
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import TextIO

from manigraph_shared.bus import Bus
from manigraph_shared.errors import CONFIG_EXIT_CODE, ManigraphError

COLOURS = ("36", "33", "35", "32", "34", "31")


@dataclass(frozen=True)
class ProcessSpec:
    name: str
    args: list[str]
    env: dict[str, str] = field(default_factory=dict)

    def argv(self) -> list[str]:
        return [sys.executable, "-m", "manigraph_shared.cli", *self.args]


#: Processes whose death stops the stack instead of being restarted.
NOT_RESTARTED = frozenset({"router"})


@dataclass(frozen=True)
class RestartPolicy:
    first_delay: float = 0.5
    max_delay: float = 10.0
    max_restarts: int = 5
    stable_after: float = 30.0


@dataclass
class _Child:
    spec: ProcessSpec
    process: subprocess.Popen[str]
    colour: str
    started: float
    restarts: int = 0  # in total
    in_a_row: int = 0  # since the last stable run
    restart_at: float | None = None


class Supervisor:
    def __init__(
        self,
        log_dir: Path | None = None,
        output: TextIO = sys.stderr,
        policy: RestartPolicy | None = None,
    ) -> None:
        self.log_dir = log_dir
        self.output = output
        self.policy = policy or RestartPolicy()
        self.children: list[_Child] = []
        #: Why the stack must stop (a router death, a service out of restarts), once known.
        self.failure: str | None = None
        self._pumps: list[threading.Thread] = []
        self._write_lock = threading.Lock()
        self._lock = threading.Lock()
        self._stopping = threading.Event()
        self._watcher: threading.Thread | None = None
        if log_dir is not None:
            log_dir.mkdir(parents=True, exist_ok=True)

    def start(self, spec: ProcessSpec) -> None:
        colour = COLOURS[len(self.children) % len(COLOURS)]
        self.children.append(_Child(spec, self._spawn(spec, colour), colour, time.monotonic()))

    def _spawn(self, spec: ProcessSpec, colour: str) -> subprocess.Popen[str]:
        env = {**os.environ, "PYTHONUNBUFFERED": "1", **spec.env}
        process = subprocess.Popen(
            spec.argv(),
            stdout=subprocess.PIPE,
            stderr=subprocess.STDOUT,
            stdin=subprocess.DEVNULL,
            text=True,
            env=env,
            start_new_session=True,  # Ctrl-C reaches us only; we stop children in order
        )
        pump = threading.Thread(target=self._pump, args=(spec.name, process, colour), daemon=True)
        pump.start()
        self._pumps.append(pump)
        return process

    def _say(self, text: str) -> None:
        with self._write_lock:
            self.output.write(f"{'supervisor':>10} | {text}\n")
            self.output.flush()
        if self.log_dir is not None:
            with (self.log_dir / "supervisor.log").open("a") as log:
                log.write(text + "\n")

    @property
    def restarts(self) -> dict[str, int]:
        return {child.spec.name: child.restarts for child in self.children}

    def _pump(self, name: str, process: subprocess.Popen[str], colour: str) -> None:
        assert process.stdout is not None
        log_file = (self.log_dir / f"{name}.log").open("a") if self.log_dir else None
        tty = self.output.isatty()
        label = f"\033[{colour}m{name:>10}\033[0m" if tty else f"{name:>10}"
        for line in process.stdout:
            with self._write_lock:
                self.output.write(f"{label} | {line}")
                self.output.flush()
            if log_file:
                log_file.write(line)
                log_file.flush()
        if log_file:
            log_file.close()

    # --- keeping the stack up -------------------------------------------------------------
    def watch(self, period: float = 0.2, interrupt_main: bool = True) -> None:
        """Restart dead services from a background thread; on a failure the stack cannot
        survive, set ``failure`` and (with ``interrupt_main``) send the main thread SIGINT,
        which wakes it from any wait (the ``up`` command turns it into a clean stop)."""

        def loop() -> None:
            while not self._stopping.wait(period):
                if self.poll() is not None:
                    if interrupt_main:
                        main = threading.main_thread().ident
                        assert main is not None
                        signal.pthread_kill(main, signal.SIGINT)
                    return

        self._watcher = threading.Thread(target=loop, name="supervisor", daemon=True)
        self._watcher.start()

    def poll(self) -> str | None:
        """One round: restart what is due; the failure that stops the stack, if any."""
        with self._lock:
            if self._stopping.is_set() or self.failure is not None:
                return self.failure
            now = time.monotonic()
            for child in self.children:
                self._poll_child(child, now)
                if self.failure is not None:
                    self._say(f"stopping the stack: {self.failure}")
                    break
            return self.failure

    def _poll_child(self, child: _Child, now: float) -> None:
        name = child.spec.name
        if child.restart_at is not None:
            if now >= child.restart_at:
                child.restart_at = None
                child.restarts += 1
                child.started = now
                child.process = self._spawn(child.spec, child.colour)
                self._say(f"restarted {name} (restart {child.restarts}, pid {child.process.pid})")
            return
        code = child.process.poll()
        if code is None:
            if now - child.started >= self.policy.stable_after:
                child.in_a_row = 0
            return
        if name in NOT_RESTARTED:
            self.failure = f"{name} exited with code {code}; the stack cannot run without it"
            return
        if code == CONFIG_EXIT_CODE:  # it said why above; the same options fail again
            self.failure = f"{name} refused its configuration (see its log above); not restarted"
            return
        if child.in_a_row >= self.policy.max_restarts:
            self.failure = (
                f"{name} exited with code {code} after {child.in_a_row} restarts in a row; "
                "giving up (see its log above)"
            )
            return
        delay = min(self.policy.first_delay * 2**child.in_a_row, self.policy.max_delay)
        child.in_a_row += 1
        child.restart_at = now + delay
        self._say(
            f"{name} exited with code {code}; restarting in {delay:.1f} s "
            f"({child.in_a_row}/{self.policy.max_restarts} in a row)"
        )

    def wait_alive(self, bus: Bus, names: list[str], timeout: float = 90.0) -> None:
        deadline = time.monotonic() + timeout
        while True:
            self.raise_if_failed()
            alive = bus.alive_services(timeout=1.0)
            missing = [name for name in names if name not in alive]
            if not missing:
                return
            if time.monotonic() > deadline:
                raise ManigraphError(f"services not alive after {timeout:.0f} s: {missing}")
            time.sleep(0.2)

    def raise_if_failed(self) -> None:
        """Without ``watch``: poll here. Raise the failure that stops the stack, if any."""
        failure = self.failure if self._watcher is not None else self.poll()
        if failure is not None:
            raise ManigraphError(failure)

    def stop(self, grace: float = 10.0) -> None:
        """SIGTERM every service at once (they stop in parallel, ~0.2 s each), then the ones
        of ``STOPPED_LAST`` in that order, so the recorder logs the others' last statuses and
        the router carries them; what has not exited after ``grace`` seconds is killed."""
        self._stopping.set()
        with self._lock:
            last = [c for name in STOPPED_LAST for c in self.children if c.spec.name == name]
            first = [c for c in reversed(self.children) if c not in last]
            _terminate([c.process for c in first], grace)
            for child in last:
                _terminate([child.process], grace)
        for pump in self._pumps:
            pump.join(timeout=2)


#: Stopped after every other process, one by one in this order.
STOPPED_LAST = ("recorder", "router")


def _terminate(processes: list[subprocess.Popen[str]], grace: float) -> None:
    """SIGTERM ``processes`` together; kill those still running ``grace`` seconds later."""
    running = [p for p in processes if p.poll() is None]
    for process in running:
        process.send_signal(signal.SIGTERM)
    deadline = time.monotonic() + grace
    for process in running:
        try:
            process.wait(timeout=max(0.0, deadline - time.monotonic()))
        except subprocess.TimeoutExpired:
            process.kill()
            process.wait()
