"""``manigraph status``: the state of a running stack at a glance.

Who is there comes from the services' liveliness tokens (one query for every cell); what each
one is comes from its ``ServiceStatus``: every service answers a query on its heartbeat's key
with its status at once (:meth:`manigraph_shared.service.Service.status`), and its heartbeat
(once a second) stands in for an answer that does not come, e.g. where the router's access
control is older than the query. A service alive but silent until the deadline is listed alive
with what its token says, nothing more.

What is shown: the endpoint and the cells, whether the stack is secure (and the certificate
directory this client used), each service alive or not with its version and uptime, the
planner's policy and checkpoint (file and SHA-256), the emergency stop (``estop_engaged`` with
reason, who and since when), and warnings, such as two deciders (the planner, or a person on
the demonstration page) alive in one cell: both would send actions to one robot.
"""

from __future__ import annotations

import threading
import time
from collections import Counter
from collections.abc import Iterable
from dataclasses import dataclass, field
from datetime import UTC, datetime

import zenoh

from manigraph_shared.bus import ALIVE_PREFIX, Bus
from manigraph_shared.bus_config import BusConfig
from manigraph_shared.cells import PREFIX, RESERVED, cell_key
from manigraph_shared.errors import MessageError
from manigraph_shared.messages import EstopState, ServiceStatus

#: The services that send ``Action``s: more than one alive in a cell is a mistake.
DECIDERS = ("planner", "demo-ui")
#: What the stack is expected to hold (a missing one is listed, not alive).
EXPECTED = ("router", "sim", "planner", "skills")
#: Longest wait for the statuses of the services alive (the target is an answer within 1 s).
DEFAULT_WAIT = 0.8
#: Services without a status of their own: their token is all there is.
NO_STATUS = frozenset({"router"})

Cell = str | None


def _cell_and_name(key: str, marker: str) -> tuple[Cell, str] | None:
    """``manigraph/alive/sim`` -> (None, "sim"); ``manigraph/left/alive/sim`` -> ("left",
    "sim"); ``marker`` is ``alive`` or ``status``."""
    parts = key.split("/")
    if len(parts) == 3 and parts[0] == PREFIX and parts[1] == marker:
        return None, parts[2]
    if len(parts) == 4 and parts[0] == PREFIX and parts[2] == marker and parts[1] not in RESERVED:
        return parts[1], parts[3]
    return None


@dataclass
class ServiceReport:
    cell: Cell
    name: str
    alive: bool
    #: How many processes answered as this service in this cell (two planners: 2).
    tokens: int = 0
    status: ServiceStatus | None = None

    def as_json(self, now: float) -> dict[str, object]:
        status = self.status
        out: dict[str, object] = {"service": self.name, "cell": self.cell, "alive": self.alive}
        if status is None:
            return out
        started = status.started_at
        out |= {
            "state": str(status.state),
            "version": status.version or None,
            "started_at": round(started, 3) if started else None,
            "uptime_s": round(max(0.0, now - started), 1) if started else None,
        }
        if status.detail:
            out["detail"] = status.detail
        if status.policy is not None:
            out["policy"] = status.policy
        if status.checkpoint is not None:
            out["checkpoint"] = {
                "path": status.checkpoint.path,
                "sha256": status.checkpoint.sha256,
            }
        if status.estop is not None:
            out["estop_engaged"] = status.estop.engaged
        return out


@dataclass
class StackStatus:
    endpoint: list[str]
    secure: bool
    certificate_dir: str | None
    services: list[ServiceReport] = field(default_factory=list)
    #: Seconds the answer took, from opening the bus to the last status.
    seconds: float = 0.0

    @property
    def cells(self) -> list[Cell]:
        return list(dict.fromkeys(report.cell for report in self.services))

    def in_cell(self, cell: Cell) -> list[ServiceReport]:
        return [report for report in self.services if report.cell == cell]

    def estop(self, cell: Cell) -> EstopState | None:
        """The cell's emergency stop as its services heard it: engaged if any alive service
        says so (the latest such stop), else the latest release; None if none has heard."""
        heard = [
            r.status.estop
            for r in self.in_cell(cell)
            if r.alive and r.status is not None and r.status.estop is not None
        ]
        engaged = [state for state in heard if state.engaged]
        pool = engaged or [state for state in heard if state.since is not None] or heard
        return max(pool, key=lambda state: state.since or 0.0) if pool else None

    @property
    def estop_engaged(self) -> bool:
        return any((state := self.estop(cell)) is not None and state.engaged for cell in self.cells)

    def policy(self) -> ServiceReport | None:
        """The planner that says what it serves (the default cell's first)."""
        planners = [
            r for r in self.services if r.name == "planner" and r.status and r.status.policy
        ]
        return planners[0] if planners else None

    def warnings(self) -> list[str]:
        found = []
        for cell in self.cells:
            where = f"cell {cell}" if cell else "the default cell"
            deciders = [r for r in self.in_cell(cell) if r.alive and r.name in DECIDERS]
            count = sum(max(r.tokens, 1) for r in deciders)
            if count > 1:
                names = ", ".join(
                    f"{r.name} x{r.tokens}" if r.tokens > 1 else r.name for r in deciders
                )
                found.append(
                    f"two deciders alive in {where} ({names}): both send actions to one "
                    "robot; stop one"
                )
            missing = [r.name for r in self.in_cell(cell) if not r.alive]
            if missing:
                found.append(f"not alive in {where}: {', '.join(missing)}")
        return found

    def as_json(self, now: float | None = None) -> dict[str, object]:
        now = time.time() if now is None else now
        planner = self.policy()
        checkpoint = planner.status.checkpoint if planner and planner.status else None
        engaged = [(c, s) for c in self.cells if (s := self.estop(c)) is not None and s.engaged]
        estop = engaged[0][1] if engaged else self.estop(None)
        return {
            "endpoint": self.endpoint,
            "secure": self.secure,
            "certificate_dir": self.certificate_dir,
            "cells": self.cells,
            "services": [report.as_json(now) for report in self.services],
            "policy": planner.status.policy if planner and planner.status else None,
            "checkpoint": (
                {"path": checkpoint.path, "sha256": checkpoint.sha256} if checkpoint else None
            ),
            "estop_engaged": self.estop_engaged,
            "estop": _estop_json(estop, engaged[0][0] if engaged else None),
            "warnings": self.warnings(),
            "seconds": round(self.seconds, 3),
        }


def _estop_json(state: EstopState | None, cell: Cell) -> dict[str, object] | None:
    if state is None:
        return None
    return {
        "engaged": state.engaged,
        "reason": state.reason,
        "by": state.by,
        "since": round(state.since, 3) if state.since is not None else None,
        "cell": cell,
    }


def gather(
    bus: Bus,
    config: BusConfig,
    wait: float = DEFAULT_WAIT,
    expected: Iterable[str] = EXPECTED,
    started: float | None = None,
) -> StackStatus:
    """Who is alive in every cell, and each one's status, within about ``wait`` seconds."""
    started = time.monotonic() if started is None else started
    deadline = started + wait
    #: Each (cell, service)'s statuses by process (its start time): two planners are two.
    heard: dict[tuple[Cell, str], dict[float | None, ServiceStatus]] = {}
    lock = threading.Lock()
    status_keys = f"{PREFIX}/**/status/*"

    def keep(key: str, payload: bytes) -> None:
        where = _cell_and_name(key, "status")
        if where is None:
            return
        try:
            status = ServiceStatus.decode(payload, key)
        except MessageError:
            return
        with lock:
            heard.setdefault(where, {})[status.started_at] = status

    bus.subscribe_raw(status_keys, lambda s: keep(str(s.key_expr), s.payload.to_bytes()))
    tokens: Counter[tuple[Cell, str]] = Counter()
    for reply in bus.session.liveliness().get(f"{PREFIX}/**/{_alive()}/*", timeout=wait):
        if reply.ok is not None:
            where = _cell_and_name(str(reply.ok.key_expr), _alive())
            if where is not None:
                tokens[where] += 1
    left = max(0.05, deadline - time.monotonic())
    # One query per cell (concrete keys: what a secure router's access control grants).
    queried = {cell_key(ServiceStatus.key_pattern(), cell) for cell, _ in tokens}
    pending = [
        bus.session.get(
            key,
            target=zenoh.QueryTarget.ALL,
            consolidation=zenoh.ConsolidationMode.NONE,
            timeout=left,
        )
        for key in sorted(queried | {ServiceStatus.key_pattern()})
    ]
    for replies in pending:
        for reply in replies:
            if reply.ok is not None:
                keep(str(reply.ok.key_expr), reply.ok.payload.to_bytes())
    wanted = {where for where in tokens if where[1] not in NO_STATUS}
    while time.monotonic() < deadline:  # heartbeats stand in for answers not come
        with lock:
            if wanted <= set(heard):
                break
        time.sleep(0.02)
    cells = list(dict.fromkeys([None, *sorted({c for c, _ in tokens if c}, key=str)]))
    # The default cell is expected to hold a stack unless the stack is one of named cells
    # (``up --cells N``): then only the router is there, and that is no fault.
    only_named = len(cells) > 1 and {n for c, n in tokens if c is None} <= NO_STATUS
    reports: list[ServiceReport] = []
    with lock:
        for cell in cells:
            names = sorted(n for c, n in tokens if c == cell)
            if cell is None and not only_named:
                names = list(dict.fromkeys([*expected, *names]))
            for name in names:
                alive = tokens.get((cell, name), 0) > 0
                processes = heard.get((cell, name), {}) if alive else {}
                status = max(processes.values(), key=lambda s: s.stamp) if processes else None
                count = max(len(processes), 1) if alive else 0
                reports.append(ServiceReport(cell, name, alive, count, status))
    return StackStatus(
        endpoint=list(config.connect),
        secure=config.tls,
        certificate_dir=str(config.tls_dir) if config.tls_dir is not None else None,
        services=reports,
        seconds=time.monotonic() - started,
    )


def _alive() -> str:
    """The liveliness tokens' marker segment (``alive`` of ``manigraph/alive``)."""
    return ALIVE_PREFIX.rsplit("/", 1)[-1]


def _when(stamp: float | None) -> str:
    if stamp is None:
        return "?"
    moment = datetime.fromtimestamp(stamp, UTC).strftime("%Y-%m-%d %H:%M:%S UTC")
    return f"{moment} ({max(0.0, time.time() - stamp):.0f} s ago)"


def _uptime(seconds: float | None) -> str:
    if seconds is None:
        return "-"
    whole = int(seconds)
    hours, rest = divmod(whole, 3600)
    minutes, secs = divmod(rest, 60)
    return f"{hours}h{minutes:02d}m{secs:02d}s" if hours else f"{minutes}m{secs:02d}s"


def text(status: StackStatus) -> str:
    """The status for people: a few lines and one table."""
    data = status.as_json()
    security = (
        f"secure (mutual TLS, certificates in {status.certificate_dir})"
        if status.secure
        else "NOT secure (plain TCP, no access control)"
    )
    cells = ", ".join(c or "default" for c in status.cells)
    lines = [f"stack at {', '.join(status.endpoint)}: {security}", f"cells: {cells}"]
    estop = data["estop"]
    if status.estop_engaged and isinstance(estop, dict):
        where = f" in cell {estop['cell']}" if estop.get("cell") else ""
        lines.append(
            f"ESTOP ENGAGED{where}: {estop['reason'] or 'no reason given'}; "
            f"by {estop['by'] or 'unknown'}; since {_when(estop['since'])}"
        )
    else:
        lines.append("estop: released")
    planner = status.policy()
    if planner is not None and planner.status is not None:
        checkpoint = planner.status.checkpoint
        served = f"policy: {planner.status.policy}"
        if checkpoint is not None:
            served += f" from {checkpoint.path} (sha256 {checkpoint.sha256})"
        lines.append(served)
    lines += ["", "| service | cell | state | version | uptime |", "|---|---|---|---|---|"]
    now = time.time()
    for report in status.services:
        row = report.as_json(now)
        state = "MISSING"
        if report.alive:
            silent = "alive" if report.name in NO_STATUS else "alive (no status heard)"
            state = str(row.get("state", silent))
        lines.append(
            f"| {report.name} | {report.cell or 'default'} | {state} | "
            f"{row.get('version') or '-'} | {_uptime(row.get('uptime_s'))} |"  # type: ignore[arg-type]
        )
    lines += [f"WARNING: {warning}" for warning in status.warnings()]
    return "\n".join(lines)
