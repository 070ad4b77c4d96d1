"""``manigraph router``: a Zenoh router in this Python process, so no separate binary is needed.

It also keeps the stack's emergency-stop latch (:mod:`manigraph_tools.estop_keeper`): a stop
lasts, across restarts of any service, of the router and of ``manigraph up``, until resume.

With TLS (``--tls-dir``) the router requires a client certificate from every connection and
enforces the access-control policy of ``manigraph_tools.access``: deny unless granted.
"""

from __future__ import annotations

import logging
import os
import signal
import threading
import time
from pathlib import Path

from manigraph_shared.bus import Bus
from manigraph_shared.bus_config import BusConfig
from manigraph_shared.health import HealthFile
from manigraph_shared.service import request_stop
from manigraph_tools.access import access_control, read_cell_identities
from manigraph_tools.estop_keeper import EstopKeeper, state_dir

log = logging.getLogger("manigraph.router")

#: Set by ``manigraph up``'s supervisor to its pid: the router then also stops when it is no
#: longer that process's child (belt and braces beside the parent-death signal), and a stop
#: that does not finish within :data:`STOP_GRACE` seconds ends the process outright.
SUPERVISOR_ENV = "MANIGRAPH_SUPERVISOR_PID"
STOP_GRACE = 5.0
#: Seconds from the stop request to the kernel ending the process (SIGALRM, default action),
#: whatever the interpreter is doing then: a close stuck in native code that holds the GIL
#: keeps every Python thread, the ``STOP_GRACE`` timer included, from running. A stack killed
#: mid-stop once left its router on the port this way (SIGINT, then SIGKILL of ``up``).
HARD_STOP_S = 10


def _watch_supervisor(stop: threading.Event) -> None:
    supervisor = os.environ.get(SUPERVISOR_ENV, "")
    if not supervisor.isdigit():
        return

    def watch() -> None:
        while not stop.is_set():
            if os.getppid() != int(supervisor):
                log.info("the supervisor went away: stopping")
                request_stop(stop, HARD_STOP_S)
            time.sleep(0.5)

    threading.Thread(target=watch, name="supervisor-watch", daemon=True).start()


def run_router(config: BusConfig, state: Path | None = None) -> int:
    """Route until SIGINT/SIGTERM, keeping the stack's emergency-stop latch in ``state`` (the
    state directory; default: :func:`~manigraph_tools.estop_keeper.state_dir`)."""
    stop = threading.Event()
    signal.signal(signal.SIGALRM, signal.SIG_DFL)  # the hard deadline of request_stop
    signal.signal(signal.SIGINT, lambda *_: request_stop(stop, HARD_STOP_S))
    signal.signal(signal.SIGTERM, lambda *_: request_stop(stop, HARD_STOP_S))
    _watch_supervisor(stop)
    # The certificate set's cells.json (if any) names each cell identity's cells.
    cells = read_cell_identities(config.tls_dir) if config.tls else {}
    overrides = {"access_control": access_control(cells=cells)} if config.tls else {}
    health = HealthFile.from_environment()
    health.clear()  # a killed predecessor's file says nothing about this router
    with Bus.open(config, overrides) as bus:
        keeper = EstopKeeper(bus.session, state_dir(state, config.listen))
        keeper.start()  # before the token: a service that sees the router can ask it
        bus.declare_alive("router")
        log.info("zenoh router listening on %s", ",".join(config.listen))
        if config.connect:
            log.info("linking to the router(s) at %s", ",".join(config.connect))
        if config.tls:
            log.info(
                "mutual TLS as %s; access control on (deny unless granted; %d cell identities)",
                config.tls_identity,
                len(cells),
            )
        else:
            log.warning("plain TCP: no authentication, no access control (development only)")
        health.beat()
        while not stop.wait(1.0):
            health.beat()
        health.clear()
        log.info("stopping")
        keeper.close()
        # Closing the session must not keep a stopped router alive on its port.
        timer = threading.Timer(STOP_GRACE, os._exit, args=(0,))
        timer.daemon = True
        timer.start()
    return 0
