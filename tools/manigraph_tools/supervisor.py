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

Nothing outlives the supervisor. Each child leads its own process group (so a Ctrl-C at the
terminal reaches the supervisor alone, which stops the children in order) and is signalled as
that group, its own children included. Each child also gets a parent-death signal (Linux
``PR_SET_PDEATHSIG``): SIGTERM reaches it when the supervisor dies, even by SIGKILL. After the
first stop signal, the signals of :data:`STOP_SIGNALS` no longer interrupt the stop: a second
one hurries it (:meth:`Supervisor.hurry`) instead of aborting it midway.
"""

from __future__ import annotations

import contextlib
import ctypes
import os
import signal
import subprocess
import sys
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from types import FrameType
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

#: What stops a supervised stack: Ctrl-C, ``kill``/``timeout``, the terminal closing.
STOP_SIGNALS = (signal.SIGINT, signal.SIGTERM, signal.SIGHUP)
#: The signal a child gets when its supervisor dies; it stops as on ``manigraph up``'s stop.
PARENT_DEATH_SIGNAL = signal.SIGTERM
#: After a second stop signal, how long what still runs has before it is killed.
HURRIED_GRACE = 1.0

_PR_SET_PDEATHSIG = 1


def _prctl() -> Callable[..., int] | None:
    """libc's ``prctl`` on Linux, looked up before any fork (a forked child only calls it)."""
    if not sys.platform.startswith("linux"):
        return None
    try:
        prctl: Callable[..., int] = ctypes.CDLL(None, use_errno=True).prctl  # libc's, loaded
    except (OSError, AttributeError):
        return None
    return prctl


_PRCTL = _prctl()


def _die_with(parent: int) -> None:
    """In a forked child before it runs its program: ask for ``PARENT_DEATH_SIGNAL`` when the
    thread that forked it ends; if the parent died already, go at once."""
    if _PRCTL is not None:
        _PRCTL(_PR_SET_PDEATHSIG, int(PARENT_DEATH_SIGNAL), 0, 0, 0)
    if os.getppid() != parent:
        os.kill(os.getpid(), signal.SIGKILL)


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
        #: Whether the failure is a service refusing its configuration (``CONFIG_EXIT_CODE``):
        #: ``up`` then exits with that code too, as the same refusal in one process would.
        self.failure_is_configuration = False
        self._pumps: list[threading.Thread] = []
        # re-entrant: a stop signal's handler may say something while the main thread writes
        self._write_lock = threading.RLock()
        self._lock = threading.Lock()
        self._stopping = threading.Event()
        #: Set once :meth:`stop` has ended every child: the watcher thread, which forked the
        #: restarted ones (their parent-death signal follows that thread), may end then.
        self._stopped = threading.Event()
        #: Set by a second stop signal: what still runs gets ``HURRIED_GRACE``, then SIGKILL.
        self._hurry = threading.Event()
        self._signalled = False
        #: The name of the first stop signal (``SIGINT``), once one came: ``up`` exits as
        #: that signal says (130 for Ctrl-C) after the stop.
        self.stopped_by: str | None = None
        self._output_broken = False
        self._watcher: threading.Thread | None = None
        if log_dir is not None:
            log_dir.mkdir(parents=True, exist_ok=True)

    def start(self, spec: ProcessSpec) -> None:
        colour = COLOURS[len(self.children) % len(COLOURS)]
        self.children.append(_Child(spec, self._spawn(spec, colour), colour, time.monotonic()))

    def _spawn(self, spec: ProcessSpec, colour: str) -> subprocess.Popen[str]:
        parent = os.getpid()
        env = {
            **os.environ,
            "PYTHONUNBUFFERED": "1",
            "MANIGRAPH_SUPERVISOR_PID": str(parent),  # the router watches it (zenoh_router.py)
            **spec.env,
        }
        process = subprocess.Popen(
            spec.argv(),
            stdout=subprocess.PIPE,
            stderr=subprocess.STDOUT,
            stdin=subprocess.DEVNULL,
            text=True,
            env=env,
            start_new_session=True,  # Ctrl-C reaches us only; we stop children in order
            preexec_fn=lambda: _die_with(parent),
        )
        pump = threading.Thread(target=self._pump, args=(spec.name, process, colour), daemon=True)
        pump.start()
        self._pumps.append(pump)
        return process

    def _write(self, text: str) -> None:
        """Write to the output; a closed terminal (SIGHUP) must not stop the stop, nor the
        pumps that keep the children's pipes drained."""
        with self._write_lock:
            if self._output_broken:
                return
            try:
                self.output.write(text)
                self.output.flush()
            except (OSError, ValueError):
                self._output_broken = True

    def _say(self, text: str) -> None:
        self._write(f"{'supervisor':>10} | {text}\n")
        if self.log_dir is not None:
            with (self.log_dir / "supervisor.log").open("a") as log:
                log.write(text + "\n")

    @property
    def restarts(self) -> dict[str, int]:
        return {child.spec.name: child.restarts for child in self.children}

    def _pump(self, name: str, process: subprocess.Popen[str], colour: str) -> None:
        assert process.stdout is not None
        log_file = (self.log_dir / f"{name}.log").open("a") if self.log_dir else None
        try:
            tty = self.output.isatty()
        except (OSError, ValueError):
            tty = False
        label = f"\033[{colour}m{name:>10}\033[0m" if tty else f"{name:>10}"
        for line in process.stdout:
            self._write(f"{label} | {line}")
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
            # The thread lives until every child is stopped: the children it restarted get
            # their parent-death signal when it ends.
            interrupted = False
            while not self._stopped.wait(period):
                if not interrupted and self.poll() is not None:
                    interrupted = True
                    if interrupt_main:
                        main = threading.main_thread().ident
                        assert main is not None
                        signal.pthread_kill(main, signal.SIGINT)

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
            self.failure_is_configuration = True
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

    # --- stopping -------------------------------------------------------------------------
    def handle_signals(self) -> None:
        """From the main thread: the first of ``STOP_SIGNALS`` raises ``KeyboardInterrupt``
        (the caller's ``finally`` then calls :meth:`stop`); every later one hurries the stop
        instead, so a Ctrl-C followed by SIGTERM or a closing terminal never leaves a child."""
        for signum in STOP_SIGNALS:
            signal.signal(signum, self._on_signal)

    def _on_signal(self, signum: int, _frame: FrameType | None) -> None:
        if self._signalled or self._stopping.is_set():
            if not self._hurry.is_set():
                name = signal.Signals(signum).name
                self._say(f"{name}: killing what still runs in {HURRIED_GRACE:g} s")
            self.hurry()
            return
        # First, before any other call: a second signal handled meanwhile (Python may run its
        # handler inside this one) then hurries instead of taking the first one's place.
        self._signalled = True
        self.stopped_by = name = signal.Signals(signum).name
        raise KeyboardInterrupt(name)

    @staticmethod
    def ignore_signals() -> None:
        """From the main thread, once everything is stopped: ignore ``STOP_SIGNALS``. Nothing
        is left to stop, and Python's finalization gives a handled signal its default action
        back, so a late one would kill the process as it exits, and its status would be the
        late signal's, not the first one's."""
        for signum in STOP_SIGNALS:
            signal.signal(signum, signal.SIG_IGN)

    def hurry(self) -> None:
        """Give every child still running ``HURRIED_GRACE`` seconds from now, then SIGKILL."""
        self._hurry.set()

    def stop(self, grace: float = 10.0) -> None:
        """SIGTERM every service at once (they stop in parallel, ~0.2 s each), then the ones
        of ``STOPPED_LAST`` in that order, so the recorder logs the others' last statuses and
        the router carries them; what has not exited after ``grace`` seconds (after
        :meth:`hurry`, ``HURRIED_GRACE``) is killed, its process group with it."""
        self._stopping.set()
        try:
            with self._lock:
                last = [c for name in STOPPED_LAST for c in self.children if c.spec.name == name]
                first = [c for c in reversed(self.children) if c not in last]
                _terminate([c.process for c in first], grace, self._hurry)
                for child in last:
                    _terminate([child.process], grace, self._hurry)
        finally:
            self._stopped.set()
        for pump in self._pumps:
            pump.join(timeout=2)


#: Stopped after every other process, one by one in this order.
STOPPED_LAST = ("recorder", "router")


def _terminate(
    processes: list[subprocess.Popen[str]], grace: float, hurry: threading.Event | None = None
) -> None:
    """SIGTERM ``processes`` (each as its process group) together; SIGKILL those still
    running ``grace`` seconds later, or ``HURRIED_GRACE`` after ``hurry`` is set."""
    running = [p for p in processes if p.poll() is None]
    for process in running:
        _signal_group(process, signal.SIGTERM)
    deadline = time.monotonic() + grace
    hurried = False
    while running:
        if hurry is not None and hurry.is_set() and not hurried:
            hurried = True
            deadline = min(deadline, time.monotonic() + HURRIED_GRACE)
        if time.monotonic() >= deadline:
            for process in running:
                _signal_group(process, signal.SIGKILL)
                process.wait()
            return
        running = [p for p in running if p.poll() is None]
        if running:
            time.sleep(0.02)
    for process in processes:  # a child's own children that outlived it
        _signal_group(process, signal.SIGKILL, leader_gone=True)


def _signal_group(process: subprocess.Popen[str], signum: int, leader_gone: bool = False) -> None:
    """Send ``signum`` to the process group ``process`` leads (its children too); with
    ``leader_gone``, to what is left of the group after the leader was reaped."""
    if process.poll() is not None and not leader_gone:
        return
    with contextlib.suppress(ProcessLookupError, PermissionError):
        os.killpg(process.pid, signum)
