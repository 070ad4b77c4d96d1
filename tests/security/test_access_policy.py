"""The access-control table: complete for the contract, minimal for the dangerous keys, and
documented exactly as the router enforces it."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

from manigraph_shared.messages import (
    Action,
    EpisodeRequest,
    JointTrajectoryCommand,
    Message,
    RobotCommand,
    Scene,
)
from manigraph_shared.messages.base import Delivery
from manigraph_tools.access import GRANTS, access_control
from manigraph_tools.certificates import IDENTITIES

DOC = Path(__file__).resolve().parents[2] / "docs" / "security.md"


def all_message_types() -> list[type[Message]]:
    found: list[type[Message]] = []
    pending = list(Message.__subclasses__())
    while pending:
        cls = pending.pop()
        pending += cls.__subclasses__()
        if "key" in vars(cls):
            found.append(cls)
    return found


def allowed(message: str, key: str) -> set[str]:
    """Identities the generated router policy lets send ``message`` on exactly ``key``."""
    config = access_control()
    rules = {
        rule["id"]: rule
        for rule in config["rules"]  # type: ignore[attr-defined]
        if message in rule["messages"] and rule["flows"] == ["ingress"] and key in rule["key_exprs"]
    }
    return {
        subject
        for policy in config["policies"]  # type: ignore[attr-defined]
        if set(policy["rules"]) & rules.keys()
        for subject in policy["subjects"]
    }


@pytest.mark.parametrize(
    ("message_type", "kind", "who"),
    [
        (Action, "put", {"planner", "demo-ui"}),
        (RobotCommand, "put", {"skills"}),
        (JointTrajectoryCommand, "put", {"skills"}),
        (Scene, "put", {"sim", "perception"}),
        (EpisodeRequest, "query", {"client", "demo-ui"}),
        (EpisodeRequest, "declare_queryable", {"sim"}),
    ],
)
def test_only_the_rightful_identity_may_send(
    message_type: type[Message], kind: str, who: set[str]
) -> None:
    assert allowed(kind, message_type.key) == who


def test_every_message_type_of_the_contract_has_a_sender() -> None:
    types = all_message_types()
    assert len(types) >= 12
    for message_type in types:
        kind = "query" if message_type.delivery is Delivery.QUERY else "put"
        key = message_type.key.replace("{service}", "planner")  # a per-identity key
        key = re.sub(r"\{[a-z_]+\}", "*", key)  # any other placeholder: granted as a pattern
        assert allowed(kind, key), f"{message_type.__name__}: no identity may send it"


def test_the_policy_denies_by_default_and_names_only_known_identities() -> None:
    config = access_control()
    assert config["enabled"] is True and config["default_permission"] == "deny"
    assert {name for grant in GRANTS for name in grant.identities} <= set(IDENTITIES)
    subjects = config["subjects"]
    assert all(s["cert_common_names"] == [s["id"]] for s in subjects)  # type: ignore[attr-defined]
