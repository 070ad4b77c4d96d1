"""Episodes in several robot cells at once: one client thread per cell, each on its own bus.

Each cell runs the plan's episodes on its own seeds (cell ``i`` from ``seed + i * episodes``),
so N cells are N times the evidence, not N copies of one run. A cell that fails or hangs
ends with its own named reasons and never holds another up: the threads share nothing but
the output stream, whose progress lines carry the cell's name.
"""

from __future__ import annotations

import sys
import threading
from dataclasses import replace
from typing import TextIO

from manigraph_shared.bus import Bus
from manigraph_tools.episodes import EpisodePlan, run_episodes

__all__ = ["cell_plan", "run_cells"]


def cell_plan(plan: EpisodePlan, index: int) -> EpisodePlan:
    """The plan of the ``index``-th cell (from 0): its own seeds and run id."""
    return replace(plan, seed=plan.seed + index * plan.episodes, run_id=f"{plan.run_id}-{index}")


class _Prefixed:
    """Whole lines to ``stream``, each led by ``[cell]``; one lock for every cell's lines."""

    _lock = threading.Lock()

    def __init__(self, stream: TextIO, cell: str) -> None:
        self._stream, self._cell, self._partial = stream, cell, ""

    def write(self, text: str) -> int:
        lines = (self._partial + text).split("\n")
        self._partial = lines.pop()
        with self._lock:
            for line in lines:
                self._stream.write(f"[{self._cell}] {line}\n")
        return len(text)

    def flush(self) -> None:
        with self._lock:
            self._stream.flush()


def run_cells(
    buses: dict[str, Bus], plan: EpisodePlan, progress: TextIO = sys.stderr
) -> dict[str, object]:
    """Run ``plan`` in every cell of ``buses`` (name -> that cell's bus) at once; the summary
    holds each cell's (as :func:`run_episodes` gives it) and the overall success rate."""
    summaries: dict[str, dict[str, object]] = {}
    failures: dict[str, str] = {}

    def run(index: int, cell: str, bus: Bus) -> None:
        try:
            stream = _Prefixed(progress, cell)
            summaries[cell] = run_episodes(bus, cell_plan(plan, index), stream)  # type: ignore[arg-type]
        except Exception as exc:  # a cell's client error is that cell's result
            failures[cell] = f"{type(exc).__name__}: {exc}"

    threads = [
        threading.Thread(target=run, args=(i, cell, bus), name=f"episodes-{cell}", daemon=True)
        for i, (cell, bus) in enumerate(buses.items())
    ]
    for thread in threads:
        thread.start()
    for thread in threads:
        thread.join()
    episodes = sum(int(s["episodes"]) for s in summaries.values())  # type: ignore[call-overload]
    successes = sum(
        float(s["success_rate"]) * int(s["episodes"])  # type: ignore[arg-type, call-overload]
        for s in summaries.values()
    )
    return {
        "cells": {cell: summaries.get(cell, {"error": failures.get(cell)}) for cell in buses},
        "success_rate_by_cell": {
            cell: summaries[cell]["success_rate"] if cell in summaries else 0.0 for cell in buses
        },
        "episodes": episodes,
        "success_rate": successes / episodes if episodes else 0.0,
        **({"failed_cells": failures} if failures else {}),
    }
