"""``manigraph run``: ask a running stack for N seeded episodes and summarize them.

The client resets the world through the sim's ``manigraph/world/reset`` queryable, waits for
each episode's end event and prints one progress line per episode; the summary is a dict the
command prints as the last line of its output (one JSON object).

A fault costs one episode at most. The client watches the liveliness tokens of the services
the run needs, and an episode is failed, with a named reason, and the run goes on when:

* a service goes away while it runs (``service_lost: skills``; a killed process's token is
  gone within milliseconds), since a decision or a command in flight is lost with it;
* nothing happens for ``stall_timeout`` seconds: no decision and no skill status of the
  episode (``no_progress``), e.g. a service alive but stuck;
* it does not end within ``timeout`` seconds (``timeout``), or the reset fails (``reset_failed``).

Before each episode the client waits (up to ``recover_timeout`` seconds) until every service is
back, so a service restarted by a supervisor (or by hand) takes the next episode.
"""

from __future__ import annotations

import queue
import re
import statistics
import sys
import threading
import time
import tomllib
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import TextIO

from manigraph_shared.bus import Bus
from manigraph_shared.errors import BusError, ConfigError, RequestRefused
from manigraph_shared.messages import (
    Action,
    EpisodeEvent,
    EpisodePhase,
    EpisodeRequest,
    SkillStatus,
)
from manigraph_shared.options import Interval, Options, option

AT_LEAST_ONE = Interval(1, None)
#: The services an episode needs.
RUN_SERVICES = ("sim", "planner", "skills")


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
    stall_timeout: float = option(
        30.0,
        help="fail an episode after this long without a decision or skill status",
        within=Interval(0, None, low_open=True),
        unit="s",
    )
    json: bool = option(False, help="print only the JSON summary (stdout, one line)")

    def task_text(self) -> str | None:
        """The task file's text (validated later, by the sim), or None without one."""
        return read_task_file(self.task_file)

    def label(self) -> str:
        """What episodes are named after: the task file's name (its stem, as an identifier),
        else the task and K."""
        if self.task_file is None and self.task == "dishwasher":
            return f"dishwasher-{self.objects}" if self.objects else "dishwasher"
        if self.task_file is None:
            return f"{self.task}-{self.blocks}"
        return re.sub(r"[^A-Za-z0-9_.\-]+", "-", self.task_file.stem)[:40] or "task-file"

    def plan(self, episodes: int, run_id: str = "run") -> EpisodePlan:
        task_file = self.task_text()
        about = describe_task_file(task_file) if task_file is not None else None
        return EpisodePlan(
            task="file" if task_file is not None else self.task,
            task_file=task_file,
            task_file_name=self.label() if task_file is not None else None,
            name=about[0] if about else None,
            blocks=about[1] if about else self.blocks,
            stacks=self.stacks,
            objects=self.objects,
            preference=self.preference,
            episodes=episodes,
            seed=self.seed,
            timeout=self.timeout,
            stall_timeout=self.stall_timeout,
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
    #: Wall-clock seconds from the reset request to the end event.
    seconds: float
    reason: str
    #: Simulated seconds, from a world with a clock (physics); None otherwise.
    sim_seconds: float | None = None


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
    task_file_name: str | None = None  # what the file is called (its stem)
    name: str | None = None  # the file's own ``name``
    #: No decision and no skill status of the episode for this long fails it.
    stall_timeout: float = 30.0
    #: Longest wait for every service to be back before an episode.
    recover_timeout: float = 60.0
    services: tuple[str, ...] = RUN_SERVICES
    objects: int | None = None  # dishwasher
    preference: str | None = None  # dishwasher

    def describe(self) -> str:
        """What the episodes are, for progress lines: the dishwasher's dishes and
        preference (each as asked: left out, the sim's default), else the task (or file)
        and K."""
        if self.task == "dishwasher":
            asked = [f"{self.objects} dishes" if self.objects else "", self.preference or ""]
            return " ".join(["dishwasher", *filter(None, asked)])
        return f"{self.task_file_name or self.task} K={self.blocks}"

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


def describe_task_file(text: str) -> tuple[str | None, int] | None:
    """The file's ``name`` and its number of blocks (spares included), read leniently for
    naming episodes and summaries: the sim validates the file, and refuses it naming the
    field. None when the text is not TOML."""
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError:
        return None
    objects = data.get("objects")
    blocks = (
        sum(isinstance(o, dict) and o.get("category") == "block" for o in objects)
        if isinstance(objects, list)
        else 0
    )
    name = data.get("name")
    # A file without blocks is still the sim's to refuse, naming the field: K stays >= 1 here.
    return (name if isinstance(name, str) else None, max(blocks, 1))


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


class ServiceWatch:
    """Which of ``services`` are alive, and which were lost since :meth:`mark`."""

    def __init__(self, bus: Bus, services: tuple[str, ...]) -> None:
        self.services = services
        self._alive: set[str] = set()  # filled by the watch: it reports who is alive now
        self._lost: list[str] = []
        self._changed = threading.Condition()
        bus.watch_alive(self._on_change)

    def _on_change(self, name: str, alive: bool) -> None:
        if name not in self.services:
            return
        with self._changed:
            if alive:
                self._alive.add(name)
            else:
                self._alive.discard(name)
                self._lost.append(name)
            self._changed.notify_all()

    def mark(self) -> None:
        with self._changed:
            self._lost.clear()

    def lost(self) -> list[str]:
        with self._changed:
            return list(dict.fromkeys(self._lost))

    def lost_within(self, seconds: float) -> list[str]:
        """The services lost since :meth:`mark`, waiting up to ``seconds`` for one."""
        with self._changed:
            self._changed.wait_for(lambda: bool(self._lost), seconds)
            return list(dict.fromkeys(self._lost))

    def wait_all_alive(self, timeout: float) -> list[str]:
        """Wait until every service is alive; returns the missing ones after ``timeout``."""
        with self._changed:
            self._changed.wait_for(lambda: set(self.services) <= self._alive, timeout)
            return sorted(set(self.services) - self._alive)


class EpisodeProgress:
    """End events, and when the running episode last made progress (a decision or a status)."""

    def __init__(self, bus: Bus) -> None:
        self.ends: queue.SimpleQueue[EpisodeEvent] = queue.SimpleQueue()
        self.episode_id = ""
        self._decisions: set[str] = set()
        self.last = time.monotonic()
        self._lock = threading.Lock()
        bus.subscribe(EpisodeEvent, self._on_event)
        bus.subscribe(Action, self._on_action)
        bus.subscribe(SkillStatus, self._on_status)

    def start(self, episode_id: str) -> None:
        with self._lock:
            self.episode_id = episode_id
            self._decisions.clear()
            self.last = time.monotonic()

    def _on_event(self, event: EpisodeEvent) -> None:
        if event.phase is EpisodePhase.END:
            self.ends.put(event)

    def _on_action(self, action: Action) -> None:
        with self._lock:
            if action.episode_id == self.episode_id:
                self._decisions.add(action.decision_id)
                self.last = time.monotonic()

    def _on_status(self, status: SkillStatus) -> None:
        with self._lock:
            if status.decision_id in self._decisions:
                self.last = time.monotonic()

    def idle_for(self) -> float:
        with self._lock:
            return time.monotonic() - self.last


def run_episodes(bus: Bus, plan: EpisodePlan, progress: TextIO = sys.stderr) -> dict[str, object]:
    """Run ``plan``'s episodes one after the other; a failed one is a result, not an error.
    Ctrl-C ends the run early with the episodes finished so far."""
    watch = ServiceWatch(bus, plan.services)
    events = EpisodeProgress(bus)
    results: list[EpisodeResult] = []
    interrupted = False
    try:
        for index in range(plan.episodes):
            result = _run_one(bus, plan, index, watch, events)
            results.append(result)
            mark = "success" if result.success else f"FAILED ({result.reason})"
            print(
                f"episode {index + 1}/{plan.episodes} {plan.describe()} "
                f"seed {result.seed}: {mark}, {result.goals_filled}/{result.goals_total} goals, "
                f"{result.steps} steps, {result.seconds:.2f} s"
                + (f" ({result.sim_seconds:.2f} s simulated)" if result.sim_seconds else ""),
                file=progress,
                flush=True,
            )
    except KeyboardInterrupt:
        interrupted = True
    summary = summarize(plan, results)
    if interrupted:
        summary["interrupted"] = True
    return summary


def _run_one(
    bus: Bus, plan: EpisodePlan, index: int, watch: ServiceWatch, events: EpisodeProgress
) -> EpisodeResult:
    request = plan.request(index)
    started = time.monotonic()

    def failed(reason: str, last: EpisodeEvent | None = None) -> EpisodeResult:
        return EpisodeResult(
            episode_id=request.episode_id,
            seed=request.seed,
            success=False,
            goals_filled=last.goals_filled if last else 0,
            goals_total=last.goals_total if last else 0,
            steps=last.steps if last else 0,
            seconds=round(time.monotonic() - started, 3),
            reason=reason,
        )

    missing = watch.wait_all_alive(plan.recover_timeout)
    if missing:
        return failed(f"service_missing: {', '.join(missing)}")
    watch.mark()
    events.start(request.episode_id)
    try:
        start = bus.request(request, EpisodeEvent, timeout=min(plan.timeout, 30.0))
    except RequestRefused:  # the request itself was refused (a bad task file): abort
        raise
    except BusError as exc:
        lost = watch.lost_within(0.5)  # killed while it answered? Its token goes too: say so
        return failed(f"service_lost: {', '.join(lost)}" if lost else f"reset_failed: {exc}"[:256])
    deadline = started + plan.timeout
    while True:
        lost = watch.lost()
        if lost:
            return failed(f"service_lost: {', '.join(lost)}", start)
        if events.idle_for() > plan.stall_timeout:
            return failed(f"no_progress: nothing for {plan.stall_timeout:g} s", start)
        if time.monotonic() > deadline:
            return failed(f"timeout: no end within {plan.timeout:g} s", start)
        try:
            end = events.ends.get(timeout=0.05)
        except queue.Empty:
            continue
        if end.episode_id == request.episode_id:
            return EpisodeResult(
                episode_id=request.episode_id,
                seed=request.seed,
                success=bool(end.success),
                goals_filled=end.goals_filled,
                goals_total=end.goals_total,
                steps=end.steps,
                seconds=round(time.monotonic() - started, 3),
                reason=end.reason,
                sim_seconds=end.sim_seconds,
            )


def _size(plan: EpisodePlan) -> dict[str, object]:
    """What the episodes hold: dishes and the preference, or blocks and stacks."""
    if plan.task == "dishwasher":
        return {"objects": plan.objects, "preference": plan.preference}
    return {"blocks": plan.blocks, "stacks": plan.stacks}


def summarize(plan: EpisodePlan, results: list[EpisodeResult]) -> dict[str, object]:
    count = len(results)
    named = {"task_file": plan.task_file_name, "name": plan.name} if plan.task_file else {}
    return {
        "task": plan.task,
        **named,
        **_size(plan),
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
        **_simulated(results),
        "results": [asdict(r) for r in results],
    }


def _simulated(results: list[EpisodeResult]) -> dict[str, float]:
    """Mean simulated seconds per episode and the real-time factor (simulated over wall time:
    1 in real time, ~30 flat out), over the episodes whose world has a clock."""
    timed = [r for r in results if r.sim_seconds is not None]
    if not timed:
        return {}
    simulated = sum(r.sim_seconds or 0.0 for r in timed)
    wall = sum(r.seconds for r in timed)
    return {
        "mean_sim_seconds": round(simulated / len(timed), 3),
        "realtime_factor": round(simulated / wall, 3) if wall > 0 else 0.0,
    }
