"""``manigraph run``: ask a running stack for N seeded episodes and summarize them.

The client resets the world through the sim's ``manigraph/world/reset`` queryable, waits for
each episode's end event and prints one progress line per episode; the summary is a dict the
command prints as the last line of its output (one JSON object).
"""

from __future__ import annotations

import queue
import statistics
import sys
import time
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import TextIO

from manigraph_shared.bus import Bus
from manigraph_shared.errors import BusError, ConfigError
from manigraph_shared.messages import EpisodeEvent, EpisodePhase, EpisodeRequest
from manigraph_shared.options import Interval, Options, option

AT_LEAST_ONE = Interval(1, None)


@dataclass(frozen=True)
class EpisodeOptions(Options):
    """Which episodes to run: the flags ``manigraph run``, ``up`` and ``eval`` share
    (``add_option_arguments(parser, EpisodeOptions)``)."""

    task: str = option("stack", help="task name")
    task_file: Path | None = option(None, help="your own TOML layout (docs/running.md)")
    blocks: int = option(4, help="blocks per stack K", within=AT_LEAST_ONE)
    stacks: int = option(1, help="number of stacks s", within=AT_LEAST_ONE)
    objects: int | None = option(
        None, help="dishes (dishwasher: half plates, half bowls; default 10)", within=AT_LEAST_ONE
    )
    preference: str | None = option(
        None, help="how to load the dishwasher: top-bottom (default) or left-right"
    )
    episodes: int | None = option(
        None,
        help="run N episodes, then exit (up without it: keep the stack running)",
        within=AT_LEAST_ONE,
    )
    seed: int = option(0, help="seed of the first episode", within=Interval(0, None))
    timeout: float = option(
        120.0, help="seconds per episode", within=Interval(0, None, low_open=True)
    )
    json: bool = option(False, help="print only the JSON summary (stdout, one line)")

    def task_text(self) -> str | None:
        """The task file's text (validated later, by the sim), or None without one."""
        return read_task_file(self.task_file)

    def plan(self, episodes: int, run_id: str = "run") -> EpisodePlan:
        task_file = self.task_text()
        return EpisodePlan(
            task="file" if task_file is not None else self.task,
            task_file=task_file,
            blocks=self.blocks,
            stacks=self.stacks,
            objects=self.objects,
            preference=self.preference,
            episodes=episodes,
            seed=self.seed,
            timeout=self.timeout,
            run_id=run_id,
        )


@dataclass(frozen=True)
class EpisodeResult:
    episode_id: str
    seed: int
    success: bool
    goals_filled: int
    goals_total: int
    steps: int
    seconds: float
    reason: str


@dataclass(frozen=True)
class EpisodePlan:
    task: str
    blocks: int
    stacks: int
    episodes: int
    seed: int
    timeout: float = 120.0
    run_id: str = "run"
    task_file: str | None = None  # TOML text of a user layout
    objects: int | None = None  # dishwasher
    preference: str | None = None  # dishwasher

    def request(self, index: int) -> EpisodeRequest:
        seed = self.seed + index
        return EpisodeRequest(
            episode_id=f"{self.run_id}-{index:04d}",
            task="file" if self.task_file is not None else self.task,
            blocks=self.blocks,
            stacks=self.stacks,
            objects=self.objects,
            preference=self.preference,
            seed=seed,
            task_file=self.task_file,
        )


def read_task_file(path: Path | None) -> str | None:
    """The text of a ``--task-file`` (validated later, by the sim), or None without one."""
    if path is None:
        return None
    try:
        return path.read_text()
    except OSError as exc:
        raise ConfigError("task-file", f"cannot read {path}: {exc.strerror}") from None


def run_episodes(bus: Bus, plan: EpisodePlan, progress: TextIO = sys.stderr) -> dict[str, object]:
    ends: queue.SimpleQueue[EpisodeEvent] = queue.SimpleQueue()
    bus.subscribe(
        EpisodeEvent, lambda event: ends.put(event) if event.phase is EpisodePhase.END else None
    )
    results = []
    for index in range(plan.episodes):
        request = plan.request(index)
        started = time.monotonic()
        bus.request(request, EpisodeEvent, timeout=plan.timeout)
        end = _wait_for_end(ends, request.episode_id, plan.timeout)
        result = EpisodeResult(
            episode_id=request.episode_id,
            seed=request.seed,
            success=bool(end.success),
            goals_filled=end.goals_filled,
            goals_total=end.goals_total,
            steps=end.steps,
            seconds=round(time.monotonic() - started, 3),
            reason=end.reason,
        )
        results.append(result)
        mark = "success" if result.success else f"FAILED ({result.reason})"
        print(
            f"episode {index + 1}/{plan.episodes} {plan.task} K={plan.blocks} seed {result.seed}: "
            f"{mark}, {result.goals_filled}/{result.goals_total} goals, {result.steps} steps, "
            f"{result.seconds:.2f} s",
            file=progress,
            flush=True,
        )
    return summarize(plan, results)


def _wait_for_end(
    ends: queue.SimpleQueue[EpisodeEvent], episode_id: str, timeout: float
) -> EpisodeEvent:
    deadline = time.monotonic() + timeout
    while True:
        remaining = deadline - time.monotonic()
        if remaining <= 0:
            raise BusError(f"episode {episode_id} did not end within {timeout:.0f} s")
        try:
            event = ends.get(timeout=remaining)
        except queue.Empty:
            continue
        if event.episode_id == episode_id:
            return event


def summarize(plan: EpisodePlan, results: list[EpisodeResult]) -> dict[str, object]:
    count = len(results)
    return {
        "task": plan.task,
        "blocks": plan.blocks,
        "stacks": plan.stacks,
        "seed": plan.seed,
        "episodes": count,
        "success_rate": sum(r.success for r in results) / count if count else 0.0,
        "goals_filled_rate": (
            statistics.fmean(r.goals_filled / max(r.goals_total, 1) for r in results)
            if count
            else 0.0
        ),
        "mean_steps": statistics.fmean(r.steps for r in results) if count else 0.0,
        "mean_seconds": statistics.fmean(r.seconds for r in results) if count else 0.0,
        "results": [asdict(r) for r in results],
    }
