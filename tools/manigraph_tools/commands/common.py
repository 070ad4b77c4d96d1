"""What every command prints: one JSON line (floats to ``results.FLOAT_DIGITS`` decimals),
and for people a readable line first."""

from __future__ import annotations

import json
import sys
import time

from manigraph_shared.bus import Bus
from manigraph_shared.results import rounded


def emit_json(summary: dict[str, object], readable: bool = False) -> None:
    """The summary as one JSON line on stdout; with ``readable``, first a line for people on
    stderr."""
    if readable and "success_rate" in summary:
        print(
            f"{summary.get('episodes')} episodes of "
            f"{summary.get('task_file') or summary.get('task')}: "
            f"success {summary['success_rate']:.3f}, "
            f"goals filled {summary.get('goals_filled_rate', float('nan')):.3f}",
            file=sys.stderr,
            flush=True,
        )
    print(json.dumps(rounded(summary)), flush=True)


def wait_services(bus: Bus, names: list[str], timeout: float = 60.0) -> None:
    """Return once every named service is alive on the bus; exit naming the missing ones."""
    deadline = time.monotonic() + timeout
    while names and not set(names) <= bus.alive_services(timeout=1.0):
        if time.monotonic() > deadline:
            missing = set(names) - bus.alive_services()
            raise SystemExit(f"manigraph: services not alive: {sorted(missing)}")
        time.sleep(0.2)
