"""A soak's stack: router, sim, planner, skills and recorder as real processes on loopback,
with per-service RSS and the counters of their ``ServiceStatus`` heartbeats.

Before any reading, every key of the contract gets a few 200 KB payloads: the first message
a Zenoh session receives that needs reassembly (larger than a 64 KB batch) grows its receive
buffers once by ~20-40 MiB — in the router too, which runs no manigraph code — and they stay
at that size (measured: the same +40 MiB after 20 and after 1,000 such payloads; queries
grow their own once more). A real stack gets there with its first long joint trajectory or
big reset; the soak's baselines start from there, so what they show is growth caused by the
load.
"""

from __future__ import annotations

import os
import threading
import time
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

from manigraph_shared.bus import Bus
from manigraph_shared.messages import Delivery, ServiceStatus
from manigraph_testkit.flood import concrete_key, rss_mb
from manigraph_testkit.fuzzing import message_types
from manigraph_testkit.testing import Stack, stack

SERVICES = ("sim", "planner", "skills", "recorder")


class SoakStack:
    def __init__(self, running: Stack, bus: Bus, log: Path) -> None:
        self.running = running
        self.bus = bus
        self.log = log
        self.beats: dict[str, ServiceStatus] = {}
        self._lock = threading.Lock()
        bus.subscribe(ServiceStatus, self._beat, on_error=lambda _error: None)

    def _beat(self, status: ServiceStatus) -> None:
        with self._lock:
            self.beats[status.service] = status

    def rss(self) -> dict[str, float]:
        return {name: rss_mb(self.running.processes[name].pid) for name in SERVICES}

    def rejected(self) -> dict[str, int]:
        with self._lock:
            return {name: self.beats[name].messages_rejected for name in SERVICES}

    def dead(self) -> list[str]:
        return [n for n, p in self.running.processes.items() if p.poll() is not None]

    def healthy(self, stall_seconds: float = 10.0) -> bool:
        """``doctor``: every service alive and its heartbeat (1 s) not missing for
        ``stall_seconds`` (doctor's default is 3; a 2-core machine at load 30+ can starve a
        healthy service that long)."""
        doctor = ("doctor", "--expect", "router", *SERVICES, "--stall-seconds", str(stall_seconds))
        return self.running.run(*doctor, timeout=1800).returncode == 0


@contextmanager
def soak_stack(tmp: Path, policy: str = "expert", record: bool = True) -> Iterator[SoakStack]:
    with stack(tmp) as running:
        running.start("router")
        log = tmp / "soak.mcap"
        names = list(SERVICES if record else SERVICES[:-1])
        if record:
            running.start("recorder", "record", "--output", str(log))
        running.start("sim", "sim")
        running.start("planner", "planner", "--policy", policy)
        running.start("skills", "skills")
        with running.client(wait_seconds=600) as bus:  # a loaded machine starts slowly
            running.wait_alive(bus, "router", *names, timeout=600)
            soak = SoakStack(running, bus, log)
            for cls in message_types():  # grow Zenoh's reassembly buffers once (see above)
                for _ in range(5):
                    junk = os.urandom(200_000)
                    if cls.delivery is Delivery.QUERY:
                        list(bus.session.get(concrete_key(cls), payload=junk, timeout=10.0))
                    else:
                        bus.put_raw(concrete_key(cls), junk, cls.delivery)
            time.sleep(1.5)  # first heartbeats
            yield soak
