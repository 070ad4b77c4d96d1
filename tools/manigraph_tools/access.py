"""Who may do what on the bus: one table, turned into the router's Zenoh access-control policy.

Every connection to a TLS router presents a certificate made by ``manigraph certs``; its
common name is the *identity* below. The router denies by default and allows, per identity,
only the rows of :data:`GRANTS` on the messages it receives from that identity (ingress).
What the router forwards (egress) is not filtered again: it only forwards what some identity
was allowed to send. Reading is open to every authenticated identity: the bus carries no
secrets, and what must be protected is who can *move* the robot or the world.

``{identity}`` in a key expression stands for the identity itself, so each service may only
announce its own liveliness token and publish its own status.

**Cells** (docs/scaling.md). The bare identities above act in the default cell only. A
process of robot cell ``cell-1`` presents ``<service>.<cell>``, e.g. ``sim.cell-1``: the same
rows, on the cell's keys (``manigraph/cell-1/robot/command``) and nowhere else, so cell A's
identities can neither move cell B's robot nor reset its world. A process serving several
cells (one planner for many) presents ``<service>.<label>`` and the certificate set's
``cells.json`` names its cells (:func:`write_cell_identities`). Routers (``router``,
``router.<site>``) relay: what another site's router forwards was checked at that router's
own ingress.

``manigraph certs --policy`` prints the table; ``docs/security.md`` holds a copy, kept from
drifting by a test.
"""

from __future__ import annotations

import json
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path

from manigraph_shared.bus import ALIVE_PREFIX
from manigraph_shared.cells import cell_key, check_cell
from manigraph_shared.errors import ConfigError
from manigraph_shared.messages import (
    Action,
    CameraInfo,
    CompressedImage,
    DepthImage,
    EmergencyStop,
    EpisodeEvent,
    EpisodeRequest,
    ExplainRequest,
    Explanation,
    JointState,
    JointTrajectoryCommand,
    JointTrajectoryResult,
    MarkerDetections,
    RobotCommand,
    RobotFeedback,
    Scene,
    SkillStatus,
    TaskLayout,
)
from manigraph_shared.messages.base import PREFIX
from manigraph_shared.messages.status import ServiceStatus
from manigraph_tools.certificates import IDENTITIES

#: Zenoh 1.x access-control message kinds, grouped by what a process does.
PUBLISH = ("put", "delete")
SERVE = ("declare_queryable", "reply")
QUERY = ("query",)
ANNOUNCE = ("liveliness_token",)
READ = ("declare_subscriber", "liveliness_query", "declare_liveliness_subscriber")
EVERY_MESSAGE = PUBLISH + SERVE + QUERY + ANNOUNCE + READ

SERVICES = ("sim", "perception", "planner", "skills", "recorder", "demo-ui")
ROUTER = "router"
#: Between a service and its cell (or its label) in a certificate's CN: ``sim.cell-1``.
CELL_SEPARATOR = "."
#: The identities each cell gets from ``manigraph certs --cells`` (the router relays, the
#: viewer only reads: neither needs one per cell).
CELL_SERVICES = ("sim", "perception", "planner", "skills", "recorder", "client", "demo-ui")
#: The file in a certificate directory that names each cell identity's cells.
CELLS_FILE = "cells.json"


@dataclass(frozen=True)
class Grant:
    """``identities`` may send ``messages`` on ``key_exprs`` to the router."""

    identities: tuple[str, ...]
    messages: tuple[str, ...]
    key_exprs: tuple[str, ...]
    why: str


GRANTS: tuple[Grant, ...] = (
    Grant(
        ("planner", "demo-ui"),
        PUBLISH,
        (Action.key,),
        "only a decider: the planner, or a person on the demonstration page",
    ),
    Grant(("planner",), PUBLISH, (Explanation.key,), "why it decided"),
    Grant(("planner",), SERVE, (ExplainRequest.key,), "answers explain requests"),
    Grant(
        ("skills",),
        PUBLISH,
        (RobotCommand.key, JointTrajectoryCommand.key),
        "only skills command the robot",
    ),
    Grant(("skills",), PUBLISH, (SkillStatus.key,), "progress of each decision"),
    Grant(("sim", "perception"), PUBLISH, (Scene.key,), "only a world source publishes scenes"),
    Grant(
        ("sim",),
        PUBLISH,
        (RobotFeedback.key, JointTrajectoryResult.key, JointState.key),
        "the simulated robot answers",
    ),
    Grant(("sim",), PUBLISH, (EpisodeEvent.key,), "episode start and end"),
    Grant(
        ("sim", "perception"),
        PUBLISH,
        (
            CompressedImage.key_pattern(),
            DepthImage.key_pattern(),
            CameraInfo.key_pattern(),
            TaskLayout.key,
        ),
        "a camera's images, depth and intrinsics, the episode's layout",
    ),
    Grant(("perception",), PUBLISH, (MarkerDetections.key_pattern(),), "what it detected"),
    Grant(("sim",), SERVE, (EpisodeRequest.key,), "the sim answers resets"),
    Grant(
        ("client", "demo-ui"),
        QUERY,
        (EpisodeRequest.key,),
        "only the episode client (or the demonstration page) resets the world",
    ),
    Grant(("client",), QUERY, (ExplainRequest.key,), "asks the planner why"),
    Grant(("client",), PUBLISH, (EmergencyStop.key,), "an operator stops or resumes the robot"),
    Grant(
        SERVICES,
        PUBLISH,
        (ServiceStatus.key.replace("{service}", "{identity}"),),
        "each service its own heartbeat",
    ),
    Grant(
        SERVICES,
        SERVE,
        (ServiceStatus.key.replace("{service}", "{identity}"),),
        "each service answers status queries for itself (`manigraph status`)",
    ),
    Grant(
        IDENTITIES,
        QUERY,
        (ServiceStatus.key_pattern(), cell_key(ServiceStatus.key_pattern(), "*")),
        "asking the services' status is reading",
    ),
    Grant(
        tuple(name for name in IDENTITIES if name != ROUTER),  # (routers relay: their own row)
        QUERY,
        (EmergencyStop.key, cell_key(EmergencyStop.key, "*")),
        "asking the stack's emergency-stop latch (kept by the router) is reading",
    ),
    Grant(SERVICES, ANNOUNCE, (f"{ALIVE_PREFIX}/{{identity}}",), "each service its own token"),
    Grant(
        (ROUTER,),
        EVERY_MESSAGE,
        (f"{PREFIX}/**",),
        "another site's router relays what its own clients were granted",
    ),
    Grant(IDENTITIES, READ, (f"{PREFIX}/**",), "every identity may read"),
)


def policy_table(grants: Sequence[Grant] = GRANTS) -> str:
    """The grants as a Markdown table (docs/security.md)."""
    lines = [
        "| identity (certificate CN) | may | on key expressions | why |",
        "|---|---|---|---|",
    ]
    for grant in grants:
        who = ", ".join(f"`{name}`" for name in grant.identities)
        if set(grant.identities) == set(IDENTITIES):
            who = "every identity"
        what = ", ".join(grant.messages)
        keys = ", ".join(f"`{key}`" for key in grant.key_exprs)
        lines.append(f"| {who} | {what} | {keys} | {grant.why} |")
    return "\n".join(lines)


def service_of(identity: str) -> str:
    """The service part of an identity: ``sim.cell-1`` -> ``sim``; ``planner`` -> ``planner``."""
    return identity.partition(CELL_SEPARATOR)[0]


def cell_identities(cells: Iterable[str]) -> dict[str, tuple[str, ...]]:
    """Every :data:`CELL_SERVICES` identity of each cell: ``{"sim.cell-1": ("cell-1",), ...}``."""
    return {
        f"{service}{CELL_SEPARATOR}{check_cell(cell)}": (cell,)
        for cell in cells
        for service in CELL_SERVICES
    }


def check_cell_identities(
    identities: Mapping[str, Sequence[str]],
) -> dict[str, tuple[str, ...]]:
    """``identities`` (CN -> its cells) if each names a known service and real cells, else a
    ``ConfigError`` naming the identity. Routers may have no cells: they relay every cell."""
    checked: dict[str, tuple[str, ...]] = {}
    for identity, cells in identities.items():
        service, sep, label = identity.partition(CELL_SEPARATOR)
        known = (*CELL_SERVICES, ROUTER, "view")
        if not sep or not label or service not in known:
            raise ConfigError(
                "identity",
                f"'{identity}' is not <service>{CELL_SEPARATOR}<cell or label> with a service "
                f"of {', '.join(known)}",
            )
        if service != ROUTER and not cells:
            raise ConfigError("identity", f"'{identity}' serves no cell")
        checked[identity] = tuple(check_cell(cell) for cell in cells)
    return checked


def write_cell_identities(directory: Path, identities: Mapping[str, Sequence[str]]) -> Path:
    """Write ``cells.json`` (CN -> its cells) into a certificate directory."""
    path = directory / CELLS_FILE
    checked = check_cell_identities(identities)
    path.write_text(json.dumps({"identities": {k: list(v) for k, v in checked.items()}}, indent=2))
    return path


def read_cell_identities(directory: Path | None) -> dict[str, tuple[str, ...]]:
    """The cell identities of a certificate directory (none where it has no ``cells.json``)."""
    if directory is None or not (directory / CELLS_FILE).is_file():
        return {}
    path = directory / CELLS_FILE
    try:
        data = json.loads(path.read_text())
        identities = data["identities"]
        return check_cell_identities({str(k): [str(c) for c in v] for k, v in identities.items()})
    except (OSError, ValueError, KeyError, TypeError, AttributeError) as exc:
        raise ConfigError("tls_dir", f"{path}: not a cells file ({exc})") from None


def access_control(
    grants: Sequence[Grant] = GRANTS, cells: Mapping[str, Sequence[str]] | None = None
) -> dict[str, object]:
    """Zenoh's ``access_control`` configuration for the router: deny unless granted.

    ``cells`` maps each cell identity (``sim.cell-1``, ``planner.pool``) to the cells it
    serves: it is granted its service's rows on those cells' keys only.
    """
    in_cells = check_cell_identities(cells or {})
    rules: list[dict[str, object]] = []
    policies: list[dict[str, object]] = []
    bare = {name for grant in grants for name in grant.identities}
    identities = sorted(bare | set(in_cells))
    for index, grant in enumerate(grants):
        expanded = any("{identity}" in key for key in grant.key_exprs)
        for identity in grant.identities if expanded else ("",):
            rule_id = f"grant{index}" + (f"-{identity}" if identity else "")
            rules.append(
                {
                    "id": rule_id,
                    "messages": list(grant.messages),
                    "flows": ["ingress"],
                    "permission": "allow",
                    "key_exprs": [key.replace("{identity}", identity) for key in grant.key_exprs],
                }
            )
            subjects = [identity] if identity else list(grant.identities)
            if grant.messages == READ:  # reading is open to every identity
                subjects += list(in_cells)
            elif ROUTER in grant.identities:  # every site's router relays
                subjects += [name for name in in_cells if service_of(name) == ROUTER]
            policies.append({"rules": [rule_id], "subjects": subjects})
        if grant.messages == READ or ROUTER in grant.identities:
            continue
        rules_and_policies = _cell_rules(index, grant, in_cells)
        rules += [rule for rule, _ in rules_and_policies]
        policies += [policy for _, policy in rules_and_policies]
    rules.append(
        {
            "id": "forward",
            "messages": list(EVERY_MESSAGE),
            "flows": ["egress"],
            "permission": "allow",
            "key_exprs": [f"{PREFIX}/**"],
        }
    )
    policies.append({"rules": ["forward"], "subjects": identities})
    return {
        "enabled": True,
        "default_permission": "deny",
        "rules": rules,
        "subjects": [{"id": name, "cert_common_names": [name]} for name in identities],
        "policies": policies,
    }


def _cell_rules(
    index: int, grant: Grant, in_cells: Mapping[str, tuple[str, ...]]
) -> list[tuple[dict[str, object], dict[str, object]]]:
    """A grant's rows for the cell identities of its services: one rule per (cell, service
    where the key names it), each on that cell's keys only."""
    out: list[tuple[dict[str, object], dict[str, object]]] = []
    per_rule: dict[tuple[str, str], list[str]] = {}
    expanded = any("{identity}" in key for key in grant.key_exprs)
    for identity, cells in in_cells.items():
        service = service_of(identity)
        if service not in grant.identities:
            continue
        for cell in cells:
            per_rule.setdefault((cell, service if expanded else ""), []).append(identity)
    for (cell, service), subjects in per_rule.items():
        rule_id = f"grant{index}@{cell}" + (f"-{service}" if service else "")
        keys = [cell_key(key.replace("{identity}", service), cell) for key in grant.key_exprs]
        out.append(
            (
                {
                    "id": rule_id,
                    "messages": list(grant.messages),
                    "flows": ["ingress"],
                    "permission": "allow",
                    "key_exprs": keys,
                },
                {"rules": [rule_id], "subjects": sorted(subjects)},
            )
        )
    return out
