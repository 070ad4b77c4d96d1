"""What a service says about itself beside its health, in every heartbeat and status answer
(``ServiceStatus``): its package's version, when it started, and the emergency stop as it
knows it (:mod:`manigraph_shared.estop_latch`). ``manigraph status`` shows them
(docs/reliability.md)."""

from __future__ import annotations

import hashlib
from importlib.metadata import PackageNotFoundError, version
from pathlib import Path

from manigraph_shared.messages import Checkpoint

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
