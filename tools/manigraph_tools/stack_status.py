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
reason, who and since when) as the stack's latch holds it (the router keeps it:
:mod:`manigraph_tools.estop_keeper`) and as each service knows it, and warnings: a service
whose view of the stop disagrees with the latch, or that does not know it yet; two processes
of one service in one cell (two deciders, the planner or a person on the demonstration page,
would both send actions to one robot; two skills would both move it).
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
from manigraph_shared.estop_latch import EstopLatch, query_latch, read_answers
from manigraph_shared.messages import EmergencyStop, EstopState, ServiceStatus

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
            out["estop"] = {"engaged": status.estop.engaged, "known": status.estop.known}
        return out


@dataclass
class StackStatus:
    endpoint: list[str]
    secure: bool
    certificate_dir: str | None
    services: list[ServiceReport] = field(default_factory=list)
    #: Each cell's stop as the stack's latch (the router) holds it; a cell whose latch did not
    #: answer is missing.
    latches: dict[Cell, EstopState] = field(default_factory=dict)
    #: Seconds the answer took, from opening the bus to the last status.
    seconds: float = 0.0

    @property
    def cells(self) -> list[Cell]:
        return list(dict.fromkeys(report.cell for report in self.services))

    def in_cell(self, cell: Cell) -> list[ServiceReport]:
        return [report for report in self.services if report.cell == cell]

    def estop(self, cell: Cell) -> EstopState | None:
        """The cell's emergency stop: as the stack's latch holds it, or engaged if any alive
        service says so (the latest such stop); else the latest release; None if nobody
        knows."""
        latched = self.latches.get(cell)
        views = [r.status.estop for r in self.in_cell(cell) if r.alive and r.status]
        if latched is not None and (latched.engaged or not any(v and v.engaged for v in views)):
            return latched
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
            for report in self.in_cell(cell):
                if report.alive and report.tokens > 1 and report.name not in DECIDERS:
                    found.append(
                        f"{report.tokens} {report.name} processes alive in {where}: both act "
                        "on one robot; stop one"
                    )
            found += self._estop_disagreements(cell, where)
            missing = [r.name for r in self.in_cell(cell) if not r.alive]
            if missing:
                found.append(f"not alive in {where}: {', '.join(missing)}")
        return found

    def _estop_disagreements(self, cell: Cell, where: str) -> list[str]:
        latched = self.latches.get(cell)
        found = []
        for report in self.in_cell(cell):
            view = report.status.estop if report.alive and report.status else None
            if view is None:
                continue
            if not view.known:
                found.append(
                    f"{report.name} in {where} does not know the emergency stop yet "
                    "(no answer from the latch): it acts as stopped"
                )
            elif latched is not None and view.engaged != latched.engaged:
                found.append(
                    f"{report.name} in {where} says the emergency stop is "
                    f"{'engaged' if view.engaged else 'released'}, the stack's latch says "
                    f"{'ENGAGED' if latched.engaged else 'released'}"
                )
        if latched is None and any(r.alive for r in self.in_cell(cell)):
            found.append(f"no emergency-stop latch answered for {where}")
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
            "estop_latch": {
                (cell or "default"): _estop_json(state, cell)
                for cell, state in self.latches.items()
            },
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
    latches = _ask_latches(bus, cells, max(0.05, deadline - time.monotonic()))
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
        latches=latches,
        seconds=time.monotonic() - started,
    )


def _ask_latches(bus: Bus, cells: list[Cell], timeout: float) -> dict[Cell, EstopState]:
    """Each cell's stop as the stack's latch holds it (the cells whose latch answered); the
    cells are asked at once."""
    keys = {cell: cell_key(EmergencyStop.key, cell) for cell in cells}
    pending = {cell: query_latch(bus.session, key, timeout) for cell, key in keys.items()}
    found: dict[Cell, EstopState] = {}
    for cell, replies in pending.items():
        answers = read_answers(replies, keys[cell])
        if answers:
            latch = EstopLatch()
            latch.answered(answers)
            found[cell] = latch.state
    return found


def _alive() -> str:
    """The liveliness tokens' marker segment (``alive`` of ``manigraph/alive``)."""
    return ALIVE_PREFIX.rsplit("/", 1)[-1]


def _when(stamp: float | None) -> str:
    if stamp is None:
        return "?"
    moment = datetime.fromtimestamp(stamp, UTC).strftime("%Y-%m-%d %H:%M:%S UTC")
    return f"{moment} ({max(0.0, time.time() - stamp):.0f} s ago)"


def _view(report: ServiceReport) -> str:
    """A service's own view of the stop: ``engaged``, ``released``, ``unknown`` or ``-``."""
    if report.name == "router":
        return "keeps the latch"
    view = report.status.estop if report.alive and report.status else None
    if view is None:
        return "-"
    if not view.known:
        return "unknown (stopped)"
    return "ENGAGED" if view.engaged else "released"


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
    lines += [
        "",
        "| service | cell | state | estop (its view) | version | uptime |",
        "|---|---|---|---|---|---|",
    ]
    now = time.time()
    for report in status.services:
        row = report.as_json(now)
        state = "MISSING"
        if report.alive:
            silent = "alive" if report.name in NO_STATUS else "alive (no status heard)"
            state = str(row.get("state", silent))
        lines.append(
            f"| {report.name} | {report.cell or 'default'} | {state} | {_view(report)} | "
            f"{row.get('version') or '-'} | {_uptime(row.get('uptime_s'))} |"  # type: ignore[arg-type]
        )
    lines += [f"WARNING: {warning}" for warning in status.warnings()]
    return "\n".join(lines)
