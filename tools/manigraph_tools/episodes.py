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

A planner that cannot read the episode's scenes (a value its checkpoint never saw) says so once
in its error status; the episode ends at once with reason ``cannot_decide: <why>``
(:mod:`manigraph_shared.decision_failure`), and, as the checkpoint cannot serve this task, the
run ends too: ``aborted`` names it, and ``run`` and ``up --episodes`` exit 78. A planner whose
every option was refused by the skills says so the same way (``out_of_options: ...``): that
episode ends with that reason, and the run goes on. Each episode's result counts the skills'
refusals of its decisions by reason (``refusals``), and the summary sums them.

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
from collections import Counter
from typing import TextIO

from manigraph_shared.bus import Bus
from manigraph_shared.decision_failure import CANNOT_DECIDE, OUT_OF_OPTIONS, cannot_decide
from manigraph_shared.errors import (
    BusError,
    DrawRefused,
    ManigraphError,
    PolicyError,
    RequestRefused,
)
from manigraph_shared.estop_latch import ESTOP_ENGAGED
from manigraph_shared.messages import (
    Action,
    EpisodeEvent,
    EpisodePhase,
    ServiceStatus,
    SkillState,
    SkillStatus,
)
from manigraph_tools.episode_plan import (
    SEED_REFUSED,
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


#: Refusals of a decision the planner made on the finished scene before the world said the
#: episode had ended (a race between the last Scene and the end event): after the end event
#: they are not refusals of the episode, and decisions published after it are not counted.
ENDED_REASONS = frozenset({"episode_ended", "no_episode", "not_running_episode"})


class EpisodeProgress:
    """End events, when the running episode last made progress (a decision or a status), and
    why its planner cannot decide on it, once it said so."""

    def __init__(self, bus: Bus) -> None:
        self.ends: queue.SimpleQueue[EpisodeEvent] = queue.SimpleQueue()
        self.episode_id = ""
        self._decisions: set[str] = set()
        self._cannot_decide: str | None = None
        self._refusals: Counter[str] = Counter()
        self._closed = False  # the running episode's end event has come
        self.last = time.monotonic()
        self._lock = threading.Lock()
        bus.subscribe(EpisodeEvent, self._on_event)
        bus.subscribe(Action, self._on_action)
        bus.subscribe(SkillStatus, self._on_status)
        planner = ServiceStatus.key.format(service="planner")
        bus.subscribe(ServiceStatus, self._on_planner_status, key=planner)

    def start(self, episode_id: str) -> None:
        with self._lock:
            self.episode_id = episode_id
            self._decisions.clear()
            self._cannot_decide = None
            self._refusals = Counter()
            self._closed = False
            self.last = time.monotonic()

    def _on_planner_status(self, status: ServiceStatus) -> None:
        said = cannot_decide(status)
        with self._lock:
            if said is not None and said[0] == self.episode_id:
                self._cannot_decide = said[1]

    def cannot_decide(self) -> str | None:
        """Why the planner cannot decide on the running episode, once it said so."""
        with self._lock:
            return self._cannot_decide

    def _on_event(self, event: EpisodeEvent) -> None:
        if event.phase is EpisodePhase.END:
            with self._lock:
                if event.episode_id == self.episode_id:
                    self._closed = True
            self.ends.put(event)

    def _on_action(self, action: Action) -> None:
        with self._lock:
            if action.episode_id == self.episode_id and not self._closed:
                self._decisions.add(action.decision_id)
                self.last = time.monotonic()

    def _on_status(self, status: SkillStatus) -> None:
        with self._lock:
            if status.decision_id in self._decisions:
                self.last = time.monotonic()
                if status.state is SkillState.FAILED and not (
                    self._closed and status.reason in ENDED_REASONS
                ):
                    self._refusals[status.reason or "unknown"] += 1

    def refusals(self) -> dict[str, int]:
        """The running episode's refused decisions by the skills' reason, most first."""
        with self._lock:
            return dict(self._refusals.most_common())

    def idle_for(self) -> float:
        with self._lock:
            return time.monotonic() - self.last


#: Seconds the client waits for a reset's answer: longer than the sim's own 30 s, so that a
#: reset the sim could not finish is its named answer (``reset_timeout``, exit 1), not silence.
RESET_WAIT = 32.0

#: Reasons that end the run with their episode: an engaged emergency stop, a planner that
#: cannot read the task's scenes.
ABORTING = (ESTOP_ENGAGED, CANNOT_DECIDE)


def raise_if_aborted(summary: dict[str, object]) -> None:
    """Fail the command whose run ``summary`` says it ended early (``aborted``; a cell's
    too), naming why: a planner that cannot decide is a configuration the same run refuses
    again (``PolicyError``, 78); an engaged stop is runtime (1)."""
    cells = summary.get("cells")
    runs = [summary, *cells.values()] if isinstance(cells, dict) else [summary]
    for run in runs:
        aborted = run.get("aborted") if isinstance(run, dict) else None
        if aborted:
            reason = str(aborted)
            if reason.startswith(CANNOT_DECIDE):
                raise PolicyError(reason)
            raise ManigraphError(reason)


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
            if result.reason.startswith(ABORTING):  # every later episode would be too
                break
    except KeyboardInterrupt:
        interrupted = True
    summary = {**policy, **summarize(plan, results)}
    if results and results[-1].reason.startswith(ABORTING):
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
            refusals=events.refusals(),
        )

    missing = watch.wait_all_alive(plan.recover_timeout)
    if missing:
        return failed(f"service_missing: {', '.join(missing)}")
    watch.mark()
    events.start(request.episode_id)
    try:
        start = bus.request(request, EpisodeEvent, timeout=min(plan.timeout, RESET_WAIT))
    except RequestRefused as exc:  # the request itself was refused (a bad task file): abort
        stopped = str(exc).find(ESTOP_ENGAGED)
        if stopped >= 0:  # not the request's fault: the stack is stopped
            return failed(str(exc)[stopped:][:256])
        if DrawRefused.MARK in str(exc):  # this seed's draw only: the next seed may run
            return failed(f"{SEED_REFUSED}: {plan.task_file_name}, seed {request.seed}: {exc}")
        raise
    except BusError as exc:
        lost = watch.lost_within(0.5)  # killed while it answered? Its token goes too: say so
        return failed(f"service_lost: {', '.join(lost)}" if lost else f"reset_failed: {exc}"[:256])
    deadline = started + plan.timeout
    while True:
        lost = watch.lost()
        if lost:
            return failed(f"service_lost: {', '.join(lost)}", start)
        why = events.cannot_decide()
        if why is not None and why.startswith(OUT_OF_OPTIONS):  # this episode's options only
            return failed(why[:256], start)
        if why is not None:  # said once by the planner: no point waiting for progress
            return failed(f"{CANNOT_DECIDE}: {why}"[:256], start)
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
                rule_violations=end.rule_violations,
                refusals=events.refusals(),
            )
