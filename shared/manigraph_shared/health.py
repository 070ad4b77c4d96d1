"""A process's health as a file's age: what a container health check can read for nothing.

``MANIGRAPH_HEALTH_FILE`` names the file. A service touches it with every heartbeat of its
service thread, and a router once a second, but only while the Zenoh session is connected
(a client to a router; a router listening), so the file goes stale when the process stalls
(a handler that never returns) or loses the bus. The check is then::

    find "$MANIGRAPH_HEALTH_FILE" -newermt '-10 seconds' | grep -q .

which costs milliseconds at any load, where ``manigraph doctor`` (a Python start, every
command's parser, a Zenoh session and a liveliness query) took longer than Docker's 10 s check
timeout on a loaded two-core machine and left ready containers ``unhealthy``.
"""

from __future__ import annotations

import contextlib
import os
from pathlib import Path

import zenoh

ENVIRONMENT = "MANIGRAPH_HEALTH_FILE"
#: What the health checks of docker/Dockerfile and compose.yaml accept as fresh.
FRESH_SECONDS = 10


class HealthFile:
    """Touches ``path`` on :meth:`beat` while ``session`` is connected (``path`` None: does
    nothing; ``session`` None: a router, connected while it runs)."""

    def __init__(self, path: Path | None, session: zenoh.Session | None = None) -> None:
        self.path = path
        self.session = session

    @classmethod
    def from_environment(cls, session: zenoh.Session | None = None) -> HealthFile:
        value = os.environ.get(ENVIRONMENT, "")
        return cls(Path(value) if value else None, session)

    def connected(self) -> bool:
        """The session reaches a router or a peer (no session: a router, itself the bus)."""
        if self.session is None:
            return True
        info = self.session.info
        return bool(list(info.routers_zid()) or list(info.peers_zid()))

    def beat(self) -> None:
        if self.path is None or not self.connected():
            return
        with contextlib.suppress(OSError):  # a full or read-only /tmp must not stop a service
            self.path.touch()

    def clear(self) -> None:
        if self.path is not None:
            with contextlib.suppress(OSError):
                self.path.unlink(missing_ok=True)
