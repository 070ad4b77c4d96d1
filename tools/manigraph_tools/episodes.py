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

    def request(self, index: int) -> EpisodeRequest:
        seed = self.seed + index
        return EpisodeRequest(
            episode_id=f"{self.run_id}-{index:04d}",
            task="file" if self.task_file is not None else self.task,
            blocks=self.blocks,
            stacks=self.stacks,
            seed=seed,
            task_file=self.task_file,
        )


def read_task_file(path: Path | None) -> str | None:
    """The text of a ``--task-file`` (its layout is validated later, by the sim), or None
    without one. A file too long to travel in a reset request is refused here."""
    if path is None:
        return None
    try:
        text = path.read_text()
    except (OSError, UnicodeDecodeError) as exc:
        why = exc.strerror if isinstance(exc, OSError) else "not UTF-8 text"
        raise ConfigError("task-file", f"cannot read {path}: {why}") from None
    limit = _task_file_limit()
    if len(text) > limit:
        raise ConfigError(
            "task-file", f"{path} has {len(text):,} characters; a task file holds at most {limit:,}"
        )
    return text


def _task_file_limit() -> int:
    """``EpisodeRequest.task_file``'s max_length, from the contract itself."""
    for constraint in EpisodeRequest.model_fields["task_file"].metadata:
        if hasattr(constraint, "max_length"):
            return int(constraint.max_length)
    raise AssertionError("EpisodeRequest.task_file lost its max_length")


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
