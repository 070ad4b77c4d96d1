"""Who may do what on the bus: one table, turned into the router's Zenoh access-control policy.

Every connection to a TLS router presents a certificate made by ``manigraph certs``; its
common name is the *identity* below. The router denies by default and allows, per identity,
only the rows of :data:`GRANTS` on the messages it receives from that identity (ingress).
What the router forwards (egress) is not filtered again: it only forwards what some identity
was allowed to send. Reading is open to every authenticated identity: the bus carries no
secrets, and what must be protected is who can *move* the robot or the world.

``{identity}`` in a key expression stands for the identity itself, so each service may only
announce its own liveliness token and publish its own status.

``manigraph certs --policy`` prints the table; ``docs/security.md`` holds a copy, kept from
drifting by a test.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

from manigraph_shared.bus import ALIVE_PREFIX
from manigraph_shared.messages import (
    Action,
    CameraInfo,
    CompressedImage,
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
from manigraph_tools.certs import IDENTITIES

#: Zenoh 1.x access-control message kinds, grouped by what a process does.
PUBLISH = ("put", "delete")
SERVE = ("declare_queryable", "reply")
QUERY = ("query",)
ANNOUNCE = ("liveliness_token",)
READ = ("declare_subscriber", "liveliness_query", "declare_liveliness_subscriber")
EVERY_MESSAGE = PUBLISH + SERVE + QUERY + ANNOUNCE + READ

SERVICES = ("sim", "perception", "planner", "skills", "recorder", "demo-ui")


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
        (CompressedImage.key_pattern(), CameraInfo.key_pattern(), TaskLayout.key),
        "a camera's images and intrinsics, the episode's layout",
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
    Grant(SERVICES, ANNOUNCE, (f"{ALIVE_PREFIX}/{{identity}}",), "each service its own token"),
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


def access_control(grants: Sequence[Grant] = GRANTS) -> dict[str, object]:
    """Zenoh's ``access_control`` configuration for the router: deny unless granted."""
    rules: list[dict[str, object]] = []
    policies: list[dict[str, object]] = []
    identities = sorted({name for grant in grants for name in grant.identities})
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
            policies.append({"rules": [rule_id], "subjects": subjects})
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
