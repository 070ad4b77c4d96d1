"""``manigraph doctor``: which services are alive, which are missing and which are stalled.

*Alive* is the service's Zenoh liveliness token, held by its session. A service can hold its
token while doing nothing useful — a handler that never returns blocks its service thread —
so doctor also listens to the ``ServiceStatus`` heartbeat every service's thread publishes
each second (``manigraph_shared.service.HEARTBEAT_SECONDS``): a service alive but silent for
``stall_seconds`` is **stalled**, and unhealthy like a missing one. The router publishes no
heartbeat (it has no service thread): its token is its health.

The heartbeats also carry the emergency stop as each service heard it: an engaged stop is
reported (``ESTOP ENGAGED: <reason> (by <who>, since <when>)``, ``estop_engaged`` in the JSON)
though it fails no health check: the services are fine, and the robot is held on purpose.
"""

from __future__ import annotations

import threading
import time
from collections.abc import Iterable
from dataclasses import dataclass, field

from manigraph_shared.bus import Bus
from manigraph_shared.messages import EstopState, ServiceStatus

DEFAULT_STACK = ("router", "sim", "planner", "skills")
#: Three missed heartbeats: long enough for one slow handler (a decision, an explanation).
DEFAULT_STALL_SECONDS = 3.0
#: Alive without a heartbeat of their own.
NO_HEARTBEAT = frozenset({"router"})


@dataclass
class Health:
    names: list[str]
    missing: list[str]
    stalled: dict[str, str] = field(default_factory=dict)
    #: The emergency stop as the heartbeats heard say (engaged if any says so); None: unheard.
    estop: EstopState | None = None

    @property
    def healthy(self) -> bool:
        return not self.missing and not self.stalled

    def as_json(self) -> dict[str, object]:
        estop = self.estop
        return {
            "alive": [n for n in self.names if n not in self.missing],
            "missing": self.missing,
            "stalled": sorted(self.stalled),
            "estop_engaged": bool(estop and estop.engaged),
            "estop": (
                {"reason": estop.reason, "by": estop.by, "since": estop.since}
                if estop and estop.engaged
                else None
            ),
        }


def check(
    bus: Bus,
    expected: Iterable[str],
    timeout: float,
    stall_seconds: float = DEFAULT_STALL_SECONDS,
) -> Health:
    """Liveliness of ``expected`` (and whoever else is there), then, with ``stall_seconds``
    > 0, a heartbeat from every alive service within that window."""
    heard: set[str] = set()
    stops: dict[str, EstopState] = {}
    lock = threading.Lock()

    def beat(status: ServiceStatus) -> None:
        with lock:
            heard.add(status.service)
            if status.estop is not None:
                stops[status.service] = status.estop

    started = time.monotonic()
    if stall_seconds > 0:
        bus.subscribe(ServiceStatus, beat)
    alive = bus.alive_services(timeout=timeout)
    wanted = list(dict.fromkeys(expected))
    missing = [name for name in wanted if name not in alive]
    health = Health(sorted(alive | set(wanted)), missing)
    if stall_seconds <= 0:
        return health
    watched = sorted(alive - NO_HEARTBEAT)
    deadline = started + stall_seconds
    while time.monotonic() < deadline:
        with lock:
            if heard >= set(watched):
                break
        time.sleep(0.05)
    with lock:
        silent = [name for name in watched if name not in heard]
        health.estop = _stop_of(stops.values())
    health.stalled = {name: f"no heartbeat for {stall_seconds:g} s" for name in silent}
    return health


def _stop_of(states: Iterable[EstopState]) -> EstopState | None:
    """Engaged if any service says so (the latest such stop); else the latest heard."""
    states = list(states)
    pool = [state for state in states if state.engaged] or states
    return max(pool, key=lambda state: state.since or 0.0) if pool else None


def table(health: Health, expected: Iterable[str]) -> str:
    wanted = set(expected)
    lines = ["| service | state |", "|---|---|"]
    for name in health.names:
        if name in health.missing:
            state = "MISSING"
        elif name in health.stalled:
            state = f"STALLED ({health.stalled[name]})"
        else:
            state = "alive"
        if name not in wanted:
            state += " (extra)"
        lines.append(f"| {name} | {state} |")
    estop = health.estop
    if estop is not None and estop.engaged:
        since = (
            time.strftime("%Y-%m-%d %H:%M:%S UTC", time.gmtime(estop.since)) if estop.since else "?"
        )
        lines.append(
            f"ESTOP ENGAGED: {estop.reason or 'no reason given'} "
            f"(by {estop.by or 'unknown'}, since {since}); `manigraph resume` releases it"
        )
    return "\n".join(lines)


def unhealthy(health: Health, expected: Iterable[str]) -> bool:
    """Whether an expected service is missing or stalled (extras never fail the check)."""
    wanted = set(expected)
    return bool(health.missing) or any(name in wanted for name in health.stalled)
