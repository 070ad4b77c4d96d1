"""``manigraph doctor``: which services are alive on the bus and which are missing."""

from __future__ import annotations

from collections.abc import Iterable

from manigraph_shared.bus import Bus

DEFAULT_STACK = ("router", "sim", "planner", "skills")


def check(bus: Bus, expected: Iterable[str], timeout: float) -> tuple[list[str], list[str]]:
    alive = bus.alive_services(timeout=timeout)
    wanted = list(dict.fromkeys(expected))
    missing = [name for name in wanted if name not in alive]
    return sorted(alive | set(wanted)), missing


def table(names: list[str], missing: list[str], expected: Iterable[str]) -> str:
    wanted = set(expected)
    lines = ["| service | state |", "|---|---|"]
    for name in names:
        state = "MISSING" if name in missing else "alive"
        if name not in wanted:
            state += " (extra)"
        lines.append(f"| {name} | {state} |")
    return "\n".join(lines)
