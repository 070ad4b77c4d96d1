"""What a service says about itself beside its health, in every heartbeat and status answer
(``ServiceStatus``): its package's version, when it started, and the emergency stop as it
last heard of it. ``manigraph status`` shows them (docs/reliability.md)."""

from __future__ import annotations

import hashlib
import threading
import time
from importlib.metadata import PackageNotFoundError, version
from pathlib import Path

from manigraph_shared.messages import Checkpoint, EmergencyStop, EstopState

#: Read at most this much of a checkpoint at once while hashing it.
_CHUNK = 1 << 20


def package_version(module: str) -> str:
    """The installed version of the distribution ``module`` (``manigraph_sim.service``)
    comes from (``manigraph-sim``); that of ``manigraph-shared`` when it has none."""
    top = module.partition(".")[0].replace("_", "-")
    for name in (top, "manigraph-shared"):
        try:
            return version(name)[:64]
        except PackageNotFoundError:
            continue
    return ""


def checkpoint_of(path: str | Path) -> Checkpoint:
    """``path`` and the SHA-256 of its bytes."""
    digest = hashlib.sha256()
    with Path(path).open("rb") as handle:
        while chunk := handle.read(_CHUNK):
            digest.update(chunk)
    return Checkpoint(path=str(path)[:4096], sha256=digest.hexdigest())


class EstopWatch:
    """The emergency stop as last heard: updated from any Zenoh thread, read by the
    heartbeat."""

    def __init__(self) -> None:
        self._state = EstopState()
        self._lock = threading.Lock()

    def heard(self, message: EmergencyStop) -> None:
        state = EstopState(
            engaged=message.engaged,
            reason=message.reason,
            by=message.by,
            since=message.stamp if message.stamp > 0 else time.time(),
        )
        with self._lock:
            self._state = state

    @property
    def state(self) -> EstopState:
        with self._lock:
            return self._state

    @property
    def engaged(self) -> bool:
        return self.state.engaged

    def describe(self) -> str:
        """``estop_engaged: <reason> (by <who>)``: what a refusal because of it says."""
        state = self.state
        return stop_reason(state.reason, state.by)


#: What a refusal, or an episode's end, because of an engaged emergency stop starts with.
ESTOP_ENGAGED = "estop_engaged"


def stop_reason(reason: str, by: str) -> str:
    """``estop_engaged: <reason> (by <who>)``."""
    return f"{ESTOP_ENGAGED}: {reason or 'no reason given'}" + (f" (by {by})" if by else "")
