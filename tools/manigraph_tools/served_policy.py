"""Which policy a stack's planner serves, for the summaries of ``run`` and ``up``: its name,
and for a checkpoint its file and SHA-256 (``sage.pt`` and ``sage-seed0.pt`` are both
``gnn-sage``). The planner answers a query on its status key at once
(``manigraph_shared.service``); where no planner answers (a person decides on the
demonstration page), the summary names no policy."""

from __future__ import annotations

from manigraph_shared.bus import Bus
from manigraph_shared.errors import MessageError
from manigraph_shared.messages import ServiceStatus

#: Longest wait for the planner's status: it answers from its Zenoh thread, in milliseconds.
STATUS_WAIT = 1.0


def served_policy(bus: Bus, wait: float = STATUS_WAIT) -> dict[str, object]:
    """``{"policy": name, "checkpoint": {"path", "sha256"}}`` as the planner of ``bus``'s
    cell says (``checkpoint`` only for a policy file); ``{}`` when no planner answers."""
    key = bus.scoped(ServiceStatus.key.format(service="planner"))
    for reply in bus.session.get(key, timeout=wait):
        if reply.ok is None:
            continue
        try:
            status = ServiceStatus.decode(reply.ok.payload.to_bytes(), key)
        except MessageError:
            continue
        if status.policy is None:
            continue
        served: dict[str, object] = {"policy": status.policy}
        if status.checkpoint is not None:
            served["checkpoint"] = {
                "path": status.checkpoint.path,
                "sha256": status.checkpoint.sha256,
            }
        return served
    return {}
