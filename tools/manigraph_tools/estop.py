"""``manigraph stop`` / ``manigraph resume``: the emergency stop from the command line.

Both publish one ``EmergencyStop`` on ``manigraph/robot/estop`` (any client may, so it lands in
the MCAP log like every other message) and wait for the skills service to acknowledge it in its
status. Skills halts the driver and fails the skill under way with reason ``stopped``; the sim
halts the arm; the planner decides nothing; every action is refused until ``resume``.

Each stop says who sent it (``--by``, default ``user@host``); every service keeps the last
stop it heard and reports it in its status, so ``manigraph status`` and ``doctor`` show an
engaged stop with its reason, who and since when. While it is engaged the sim refuses new
episodes and cuts the one under way (reason ``estop_engaged``).

The stop is latched by the stack (the router keeps it across restarts:
:mod:`manigraph_tools.estop_keeper`): a service started, or restarted, after it learns it
before it moves. Both commands say whether the latch holds what they sent.
"""

from __future__ import annotations

import getpass
import socket
import threading
import time

from manigraph_shared.bus import Bus
from manigraph_shared.estop_latch import EstopLatch
from manigraph_shared.messages import EmergencyStop, ServiceStatus

ENGAGED = "emergency stop engaged"


def operator() -> str:
    """``user@host`` of this process, as well as it can be told."""
    try:
        user = getpass.getuser()
    except (OSError, KeyError):  # no user entry (a container) and no $USER
        user = "unknown"
    return f"{user}@{socket.gethostname()}"[:128]


def latched(bus: Bus, engaged: bool, wait: float = 1.0) -> bool:
    """Whether the stack's latch holds ``engaged`` now (asked until ``wait`` runs out)."""
    deadline = time.monotonic() + wait
    while True:
        latch = EstopLatch()
        if latch.ask(bus, timeout=max(0.1, deadline - time.monotonic())) and (
            latch.engaged == engaged
        ):
            return True
        if time.monotonic() >= deadline:
            return False
        time.sleep(0.05)


def send(bus: Bus, engaged: bool, reason: str, wait: float, by: str = "") -> bool:
    """Publish the stop (or its release); True once skills has acknowledged it."""
    acknowledged = threading.Event()

    def on_status(status: ServiceStatus) -> None:
        if status.service == "skills" and status.detail.startswith(ENGAGED) == engaged:
            acknowledged.set()

    bus.subscribe(ServiceStatus, on_status, key="manigraph/status/skills")
    time.sleep(0.05)  # let the subscription reach the router before the answer can
    bus.publish(EmergencyStop(engaged=engaged, reason=reason, by=by, stamp=time.time()))
    return acknowledged.wait(wait)
