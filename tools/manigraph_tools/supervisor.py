"""``manigraph up``: the router and every service of a stack as local child processes.

Each child's output is prefixed with its name (and copied to ``<log_dir>/<name>.log``); the
children are stopped in reverse start order with SIGTERM, then SIGKILL after a grace period.
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
from manigraph_shared.errors import ManigraphError

COLOURS = ("36", "33", "35", "32", "34", "31")


@dataclass(frozen=True)
class ProcessSpec:
    name: str
    args: list[str]
    env: dict[str, str] = field(default_factory=dict)

    def argv(self) -> list[str]:
        return [sys.executable, "-m", "manigraph_shared.cli", *self.args]


class Supervisor:
    def __init__(self, log_dir: Path | None = None, output: TextIO = sys.stderr) -> None:
        self.log_dir = log_dir
        self.output = output
        self.children: list[tuple[ProcessSpec, subprocess.Popen[str]]] = []
        self._pumps: list[threading.Thread] = []
        self._write_lock = threading.Lock()
        if log_dir is not None:
            log_dir.mkdir(parents=True, exist_ok=True)

    def start(self, spec: ProcessSpec) -> None:
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
        colour = COLOURS[len(self.children) % len(COLOURS)]
        self.children.append((spec, process))
        pump = threading.Thread(target=self._pump, args=(spec.name, process, colour), daemon=True)
        pump.start()
        self._pumps.append(pump)

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

    def wait_alive(self, bus: Bus, names: list[str], timeout: float = 90.0) -> None:
        deadline = time.monotonic() + timeout
        while True:
            self.raise_if_dead()
            alive = bus.alive_services(timeout=1.0)
            missing = [name for name in names if name not in alive]
            if not missing:
                return
            if time.monotonic() > deadline:
                raise ManigraphError(f"services not alive after {timeout:.0f} s: {missing}")
            time.sleep(0.2)

    def raise_if_dead(self) -> None:
        for spec, process in self.children:
            code = process.poll()
            if code is not None:
                raise ManigraphError(f"{spec.name} exited with code {code}; see its log above")

    def stop(self, grace: float = 10.0) -> None:
        for _spec, process in reversed(self.children):
            if process.poll() is None:
                process.send_signal(signal.SIGTERM)
                try:
                    process.wait(timeout=grace)
                except subprocess.TimeoutExpired:
                    process.kill()
                    process.wait()
        for pump in self._pumps:
            pump.join(timeout=2)
