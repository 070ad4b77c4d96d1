"""``manigraph router``: a Zenoh router in this Python process, so no separate binary is needed."""

from __future__ import annotations

import logging
import signal
import threading

from manigraph_shared.bus import Bus
from manigraph_shared.bus_config import BusConfig

log = logging.getLogger("manigraph.router")


def run_router(config: BusConfig) -> int:
    stop = threading.Event()
    signal.signal(signal.SIGINT, lambda *_: stop.set())
    signal.signal(signal.SIGTERM, lambda *_: stop.set())
    with Bus.open(config) as bus:
        bus.declare_alive("router")
        log.info("zenoh router listening on %s", ",".join(config.listen))
        stop.wait()
        log.info("stopping")
    return 0
