"""One process, several robot cells: one :class:`~manigraph_shared.service.Service` per cell.

A service that serves many cells (the planner) runs one instance per cell, each on its own
view of one Zenoh session (:meth:`Bus.in_cell`), with its own inbox and its own service
thread. What a cell's handlers do never waits on another cell: Zenoh's callbacks only put
samples into the inbox of the cell whose keys they arrived on, and a cell whose thread is busy
(a slow decision, an explanation) or whose world is dead delays only itself. Each instance
declares its own liveliness token and heartbeats in its cell, so to every cell the process
looks like that cell's own service. What the instances share (a loaded policy) is theirs to
make safe for concurrent use.

A cell's service that fails (``setup`` raising) stops the whole process, with that error:
the supervisor restarts it, as it would a one-cell service.
"""

from __future__ import annotations

import logging
import signal
import threading
from collections.abc import Callable, Sequence

from manigraph_shared.bus import Bus
from manigraph_shared.bus_config import BusConfig
from manigraph_shared.health import HealthFile
from manigraph_shared.service import Service, limit_malloc_arenas

__all__ = ["CellServices", "run_cell_services"]

log = logging.getLogger(__name__)


class CellServices:
    """The services of ``cells`` (``None``: the default cell) on ``bus``'s session, each on its
    own thread; :meth:`run` until :meth:`stop` or one of them fails."""

    def __init__(
        self, bus: Bus, factory: Callable[[Bus, str | None], Service], cells: Sequence[str | None]
    ) -> None:
        if not cells:
            raise ValueError("cells: name at least one cell")
        self.bus = bus
        self.views = {cell: bus.in_cell(cell) for cell in cells}
        self.services = {cell: factory(view, cell) for cell, view in self.views.items()}
        for cell, service in self.services.items():
            if cell is not None:  # each cell's log lines say whose they are
                service.log = logging.getLogger(f"{service.log.name}.{cell}")
        self.failures: dict[str | None, BaseException] = {}
        self._threads: list[threading.Thread] = []

    def start(self) -> None:
        for cell, service in self.services.items():
            thread = threading.Thread(
                target=self._run_one,
                args=(cell, service),
                name=f"{service.name}-{cell or 'default'}",
                daemon=True,
            )
            self._threads.append(thread)
            thread.start()

    def _run_one(self, cell: str | None, service: Service) -> None:
        try:
            service.run()
        except BaseException as exc:  # one cell's failure ends the process (see module doc)
            log.exception("cell %s: %s failed", cell or "default", service.name)
            self.failures[cell] = exc
            self.stop()

    def stop(self) -> None:
        for service in self.services.values():
            service.stop_event.set()

    def wait(self, poll: float = 0.2) -> None:
        """Until every service thread has ended (in slices, so signals are handled)."""
        for thread in self._threads:
            while thread.is_alive():
                thread.join(poll)

    def close(self) -> None:
        for view in self.views.values():
            view.close()

    def run(self) -> None:
        """Start, wait, close; re-raise the first cell's failure."""
        self.start()
        try:
            self.wait()
        finally:
            self.stop()
            self.wait()
            self.close()
        for exc in self.failures.values():
            raise exc


def run_cell_services(
    factory: Callable[[Bus, str | None], Service],
    bus_config: BusConfig,
    cells: Sequence[str | None],
) -> int:
    """Like :func:`~manigraph_shared.service.run_service`, one service per cell of ``cells``
    on one session, until SIGINT/SIGTERM."""
    limit_malloc_arenas()
    HealthFile.from_environment().clear()
    bus = Bus.open(bus_config)
    try:
        services = CellServices(bus, factory, cells)

        def stop(signum: int, _frame: object) -> None:
            log.info("received %s, stopping every cell", signal.Signals(signum).name)
            services.stop()

        signal.signal(signal.SIGINT, stop)
        signal.signal(signal.SIGTERM, stop)
        services.run()
    finally:
        bus.close()
    return 0
