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

An engaged emergency stop ends the run instead: the sim refuses the reset at once, or cuts the
episode under way, with reason ``estop_engaged: <why> (by <who>)``; that episode is the run's
last, and the summary names the reason under ``aborted`` (``manigraph run`` then fails).

Before each episode the client waits (up to ``recover_timeout`` seconds) until every service is
back, so a service restarted by a supervisor (or by hand) takes the next episode.
"""

from __future__ import annotations

import queue
import sys
import threading
import time
from typing import TextIO

from manigraph_shared.bus import Bus
from manigraph_shared.errors import BusError, RequestRefused
from manigraph_shared.messages import Action, EpisodeEvent, EpisodePhase, SkillStatus
from manigraph_shared.service_facts import ESTOP_ENGAGED
from manigraph_tools.episode_plan import (
    EpisodeOptions,
    EpisodePlan,
    EpisodeResult,
    read_task_file,
    summarize,
)
from manigraph_tools.served_policy import served_policy

#: Importers of the plan's names from here (``up``, ``demo-ui``, cells) keep working.
__all__ = [
    "EpisodeOptions",
    "EpisodePlan",
    "EpisodeProgress",
    "EpisodeResult",
    "ServiceWatch",
    "read_task_file",
    "run_episodes",
    "summarize",
]


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
    policy = served_policy(bus)  # the summary names what decided (and its checkpoint)
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
            if result.reason.startswith(ESTOP_ENGAGED):  # every later episode would be too
                break
    except KeyboardInterrupt:
        interrupted = True
    summary = {**policy, **summarize(plan, results)}
    if results and results[-1].reason.startswith(ESTOP_ENGAGED):
        summary["aborted"] = results[-1].reason
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
    except RequestRefused as exc:  # the request itself was refused (a bad task file): abort
        stopped = str(exc).find(ESTOP_ENGAGED)
        if stopped >= 0:  # not the request's fault: the stack is stopped
            return failed(str(exc)[stopped:][:256])
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
                goals_wrong_object=end.goals_wrong_object,
            )
