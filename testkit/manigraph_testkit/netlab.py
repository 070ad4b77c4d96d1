"""Two hosts on one machine: Linux network namespaces joined by a veth pair with a delay.

For tests and benches of several sites (docs/scaling.md, *Several hosts*). Each host is a
network namespace of its own (``ip netns``) holding only its loopback and one end of a veth
pair, addressed ``10.213.N.1`` / ``10.213.N.2``: the addresses exist only inside the
namespaces made here, and everything is removed on exit, also after a failure.

The link's delay is ``tc qdisc ... netem delay`` on each end where the kernel has netem. Where
it has not (``sch_netem`` is a module some kernels lack, and loading one needs the host),
:mod:`manigraph_testkit.delay_link` relays the router-to-router TCP connection through a
userspace queue that holds every byte ``delay`` in each direction: the same round trip for the
application, applied per chunk instead of per packet. :attr:`TwoHosts.delay_by` says which.
Cutting the link (``ip link set DEV down``) cuts it either way.
"""

from __future__ import annotations

import json
import os
import shutil
import signal
import subprocess
import sys
import time
from collections.abc import Iterator, Sequence
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path
from typing import IO

__all__ = [
    "Host",
    "Sites",
    "TwoHosts",
    "decision_latencies_ms",
    "loopback_hosts",
    "netns_problem",
]


def _ip(*args: str, check: bool = True) -> subprocess.CompletedProcess[str]:
    return subprocess.run(["ip", *args], capture_output=True, text=True, timeout=10, check=check)


def netns_problem() -> str | None:
    """Why namespaces cannot be made here, or ``None``."""
    if os.geteuid() != 0:
        return "needs root to create network namespaces (ip netns add)"
    if shutil.which("ip") is None or shutil.which("tc") is None:
        return "needs iproute2 (ip, tc)"
    name = f"mgprobe{os.getpid()}"
    made = _ip("netns", "add", name, check=False)
    if made.returncode != 0:
        return f"ip netns add failed: {made.stderr.strip()}"
    _ip("netns", "del", name, check=False)
    return None


@dataclass
class Host:
    """One namespace: its name, its address on the link and its veth end."""

    netns: str
    address: str
    device: str
    processes: list[subprocess.Popen[bytes]] = field(default_factory=list)

    def argv(self, argv: Sequence[str]) -> list[str]:
        if not self.netns:  # loopback_hosts(): this machine's own namespace
            return list(argv)
        return ["ip", "netns", "exec", self.netns, *argv]

    def sh(self, *argv: str) -> subprocess.CompletedProcess[str]:
        return subprocess.run(
            self.argv(argv), capture_output=True, text=True, timeout=30, check=True
        )

    def start(self, argv: Sequence[str], env: dict[str, str], log: Path) -> subprocess.Popen[bytes]:
        """Start ``argv`` inside this host (``ip netns exec`` execs it: the pid is its own)."""
        out: IO[bytes] = log.open("ab")
        process = subprocess.Popen(
            self.argv(argv),
            stdout=out,
            stderr=subprocess.STDOUT,
            stdin=subprocess.DEVNULL,
            env=env,
        )
        self.processes.append(process)
        return process

    def stop_all(self) -> None:
        for process in reversed(self.processes):
            if process.poll() is None:
                process.terminate()
        deadline = time.monotonic() + 10.0
        for process in self.processes:
            try:
                process.wait(timeout=max(0.1, deadline - time.monotonic()))
            except subprocess.TimeoutExpired:
                process.kill()
                process.wait(timeout=5)
        self.processes.clear()


class TwoHosts:
    """Hosts ``a`` and ``b`` joined by a veth pair, ``delay_ms`` each way.

    ``with TwoHosts(20) as hosts:`` ... every process started on a host, the namespaces and the
    veth pair are gone after the block, whatever happened inside it.
    """

    def __init__(self, delay_ms: float, subnet: int | None = None) -> None:
        self.delay_ms = delay_ms
        tag = f"{os.getpid() % 100000}"
        net = subnet if subnet is not None else os.getpid() % 250 + 1
        self.a = Host(f"mg{tag}a", f"10.213.{net}.1", f"mg{tag}a0")
        self.b = Host(f"mg{tag}b", f"10.213.{net}.2", f"mg{tag}b0")
        self.delay_by = "none"
        self._relays: list[subprocess.Popen[bytes]] = []

    def __enter__(self) -> TwoHosts:
        try:
            self._build()
        except BaseException:
            self.close()
            raise
        return self

    def __exit__(self, *_exc: object) -> None:
        self.close()

    def _build(self) -> None:
        a, b = self.a, self.b
        _ip("netns", "add", a.netns)
        _ip("netns", "add", b.netns)
        # Made inside a and moved straight into b: the pair never exists in this namespace.
        a.sh("ip", "link", "add", a.device, "type", "veth", "peer", "name", b.device,
             "netns", b.netns)  # fmt: skip
        for host in (a, b):
            host.sh("ip", "addr", "add", f"{host.address}/24", "dev", host.device)
            host.sh("ip", "link", "set", "lo", "up")
            host.sh("ip", "link", "set", host.device, "up")
        if self.delay_ms > 0:
            delay = f"{self.delay_ms / 2:g}ms"
            netem = [
                host.argv(
                    ["tc", "qdisc", "add", "dev", host.device, "root", "netem", "delay", delay]
                )
                for host in (a, b)
            ]
            results = [subprocess.run(cmd, capture_output=True, text=True, timeout=10)
                       for cmd in netem]  # fmt: skip
            self.delay_by = "netem" if all(r.returncode == 0 for r in results) else "relay"
            if self.delay_by == "relay":
                for host in (a, b):
                    subprocess.run(host.argv(["tc", "qdisc", "del", "dev", host.device, "root"]),
                                   capture_output=True, timeout=10)  # fmt: skip

    def link(self, port: int, relay_port: int, log: Path) -> str:
        """The endpoint (``HOST:PORT``) b's router connects to for a's router on ``port``: a
        itself where netem delays the link, else a relay in a adding the delay each way."""
        if self.delay_by != "relay":
            return f"{self.a.address}:{port}"
        argv = [sys.executable, "-m", "manigraph_testkit.delay_link",
                "--listen", f"{self.a.address}:{relay_port}", "--to", f"{self.a.address}:{port}",
                "--delay-ms", f"{self.delay_ms / 2:g}"]  # fmt: skip
        relay = self.a.start(argv, dict(os.environ), log)
        self._relays.append(relay)
        return f"{self.a.address}:{relay_port}"

    def cut(self) -> None:
        """Take the link down (both ends lose carrier)."""
        self.a.sh("ip", "link", "set", self.a.device, "down")

    def restore(self) -> None:
        self.a.sh("ip", "link", "set", self.a.device, "up")
        self.b.sh("ip", "link", "set", self.b.device, "up")

    def close(self) -> None:
        for host in (self.b, self.a):
            host.stop_all()
        for name in (self.a.netns, self.b.netns):
            _ip("netns", "del", name, check=False)  # takes its veth end (and so the pair)


def loopback_hosts() -> tuple[Host, Host]:
    """Two "hosts" on this machine's loopback: the same sites, no namespaces, no delay."""
    return Host("", "127.0.0.1", "lo"), Host("", "127.0.0.1", "lo")


MANIGRAPH = (sys.executable, "-m", "manigraph_shared.cli")
PROBE = (sys.executable, "-m", "manigraph_testkit.netprobe")


class Sites:
    """Two sites, each with its own router, joined by one router-to-router link.

    Site a holds each cell's sim and skills (``sim.<cell>``, ``skills.<cell>``); site b holds
    one planner for every cell (``planner.site-b``). With ``certs`` every link is mutual TLS
    and each router enforces the per-cell policy of the set's ``cells.json``. ``link`` is the
    ``HOST:PORT`` site b's router connects to (:meth:`TwoHosts.link`, or a's router itself).
    """

    def __init__(
        self,
        a: Host,
        b: Host,
        *,
        link: str,
        ports: tuple[int, int],
        certs: Path | None,
        log_dir: Path,
        cells: Sequence[str] = ("cell-1",),
        policy: str = "expert",
    ) -> None:
        self.a, self.b, self.link, self.ports = a, b, link, ports
        self.certs, self.log_dir, self.cells, self.policy = certs, log_dir, cells, policy
        self.scheme = "tls" if certs else "tcp"
        #: Each site's router process and how it was started (:meth:`restart_router`).
        self.routers: dict[str, tuple[subprocess.Popen[bytes], list[str]]] = {}

    def endpoint(self, host: Host) -> str:
        port = self.ports[0] if host is self.a else self.ports[1]
        return f"{self.scheme}/{host.address}:{port}"

    def env(self, host: Host, identity: str, cell: str | None = None) -> dict[str, str]:
        return {
            **os.environ,
            "MANIGRAPH_ZENOH_MODE": "client",
            "MANIGRAPH_ZENOH_CONNECT": self.endpoint(host),
            "MANIGRAPH_ZENOH_NO_MULTICAST_SCOUTING": "1",
            "MANIGRAPH_TLS_DIR": str(self.certs or ""),
            "MANIGRAPH_TLS_IDENTITY": identity if self.certs else "",
            "MANIGRAPH_CELL": cell or "",
            "PYTHONUNBUFFERED": "1",
        }

    def start(self) -> None:
        a, b = self.a, self.b
        log = self.log_dir
        self._start_router(a, [*MANIGRAPH, "router", "--listen", self.endpoint(a)], "a")
        link = f"{self.scheme}/{self.link}"
        self._start_router(
            b, [*MANIGRAPH, "router", "--listen", self.endpoint(b), "--connect", link], "b"
        )
        for cell in self.cells:
            for service in ("sim", "skills"):
                a.start([*MANIGRAPH, service], self.env(a, f"{service}.{cell}", cell),
                        log / f"{service}-{cell}.log")  # fmt: skip
        b.start([*MANIGRAPH, "planner", "--policy", self.policy, "--cells", ",".join(self.cells)],
                self.env(b, "planner.site-b"), log / "planner.log")  # fmt: skip

    def _start_router(self, host: Host, argv: list[str], site: str) -> None:
        env = self.env(host, f"router.site-{site}")
        process = host.start(argv, env, self.log_dir / f"router-{site}.log")
        self.routers[site] = (process, argv)

    def restart_router(self, site: str, down_seconds: float) -> float:
        """Kill site ``site``'s router (SIGKILL: no goodbye to its clients), start it again on
        the same endpoint after ``down_seconds``; the seconds it was down."""
        process, argv = self.routers[site]
        host = self.a if site == "a" else self.b
        process.kill()
        process.wait(timeout=10)
        killed = time.monotonic()
        time.sleep(down_seconds)
        self._start_router(host, argv, site)
        return time.monotonic() - killed

    def wait_ready(self, timeout: float = 150.0) -> None:
        """Until every cell's sim, skills and (across the link) planner are alive in site a."""
        for cell in self.cells:
            probe = subprocess.run(
                self.a.argv([*PROBE, "alive", "--need", "sim,skills,planner",
                             "--seconds", f"{timeout:g}"]),
                env=self.env(self.a, f"client.{cell}", cell), capture_output=True, text=True,
                timeout=timeout + 60,
            )  # fmt: skip
            if probe.returncode != 0:
                raise RuntimeError(f"{cell} never came up: {probe.stdout}{probe.stderr}"[-2000:])

    def run(
        self, cell: str, *args: str, timeout: float = 120.0
    ) -> subprocess.CompletedProcess[str]:
        """``manigraph run ARGS`` in ``cell`` from site a, as the cell's episode client."""
        return subprocess.run(
            self.a.argv([*MANIGRAPH, "run", *args]), env=self.env(self.a, f"client.{cell}", cell),
            capture_output=True, text=True, timeout=timeout,
        )  # fmt: skip

    def log(self, name: str) -> str:
        path = self.log_dir / f"{name}.log"
        return path.read_text(errors="replace") if path.exists() else ""

    @contextmanager
    def listening(self, name: str, cell: str = "cell-1") -> Iterator[list[dict[str, object]]]:
        """Every Scene, Action and RobotCommand of ``cell`` seen at site a while inside (the
        list is filled when the block ends)."""
        out = self.log_dir / f"{name}.json"
        ready = Path(f"{out}.ready")
        ready.unlink(missing_ok=True)
        process = self.a.start(
            [*PROBE, "listen", "--seconds", "600", "--out", str(out)],
            self.env(self.a, f"recorder.{cell}", cell), self.log_dir / f"{name}.log",
        )  # fmt: skip
        deadline = time.monotonic() + 30
        while not ready.exists():
            if process.poll() is not None or time.monotonic() > deadline:
                raise RuntimeError(f"the listener never started: {self.log(name)[-2000:]}")
            time.sleep(0.1)
        time.sleep(0.3)  # its subscriptions reach the router
        events: list[dict[str, object]] = []
        try:
            yield events
        finally:
            process.send_signal(signal.SIGTERM)
            process.wait(timeout=15)
            events += json.loads(out.read_text())


def decision_latencies_ms(events: list[dict[str, object]]) -> list[float]:
    """Scene stamp (the sim's clock) -> its Action's arrival at site a, per decision: both
    ends on this machine's clock."""
    stamps = {(e["episode"], e["sequence"]): e["stamp"] for e in events if e["kind"] == "scene"}
    return [
        (float(str(e["at"])) - float(str(stamps[(e["episode"], e["sequence"])]))) * 1000
        for e in events
        if e["kind"] == "action" and (e["episode"], e["sequence"]) in stamps
    ]
