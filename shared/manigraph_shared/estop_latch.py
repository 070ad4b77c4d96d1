"""The emergency stop as a service knows it: learned from the stack's latch, never assumed.

The stop is held by the stack, not by whichever process heard it: the router keeps the last
``EmergencyStop`` of every cell (``manigraph_tools.estop_keeper``) in its state directory and
answers a query on the stop's own key with it. A service

* starts **unknown**, and unknown acts as stopped (``engaged`` is true): it may not move the
  robot, start an episode or decide before it has learned the stop;
* asks the latch before it declares itself alive (:meth:`EstopLatch.ask`), and again every
  :data:`REFRESH_SECONDS` (every :data:`UNKNOWN_RETRY_SECONDS` while it does not know), so a
  service that missed a stop (it was restarting, its link dropped) learns it;
* applies every stop it hears at once, on the Zenoh thread that delivers it.

A stop heard on the bus is applied in arrival order (the latch keeps them in the order the
router received them, which is the same). An answer to a query that a stop heard meanwhile has
overtaken is stale and ignored (the next query reconciles). Where several routers answer
(linked sites), the newest answer by the stop's ``stamp`` wins, and of two equally new an
engaged one.
"""

from __future__ import annotations

import logging
import threading
import time
from collections.abc import Callable
from typing import Any

import zenoh

from manigraph_shared.bus import Bus
from manigraph_shared.errors import MessageError
from manigraph_shared.messages import EmergencyStop, EstopState

log = logging.getLogger("manigraph.estop")

#: How often a service that knows the stop asks the latch again (a missed message heals).
REFRESH_SECONDS = 5.0
#: How often a service that does not know the stop asks again.
UNKNOWN_RETRY_SECONDS = 0.5
#: Longest a service waits for the latch's answer before it declares itself alive (it then
#: runs on, stopped, and keeps asking).
FIRST_ANSWER_SECONDS = 3.0
#: What an unknown stop says, in statuses and refusals.
UNKNOWN_REASON = "stop state not yet known: no answer from the stack's latch (the router)"

#: What the latch answers for a cell whose stop was never sent.
NEVER_ENGAGED = "never engaged"

#: The state of a service that has not yet learned the stop.
UNKNOWN = EstopState(engaged=True, known=False, reason=UNKNOWN_REASON)

#: What an emergency stop refusal, or an episode's end because of one, starts with.
ESTOP_ENGAGED = "estop_engaged"


def stop_reason(reason: str, by: str) -> str:
    """``estop_engaged: <reason> (by <who>)``."""
    return f"{ESTOP_ENGAGED}: {reason or 'no reason given'}" + (f" (by {by})" if by else "")


def state_of(message: EmergencyStop) -> EstopState:
    return EstopState(
        engaged=message.engaged,
        reason=message.reason,
        by=message.by,
        since=message.stamp if message.stamp > 0 else None,
    )


def newer(candidate: EmergencyStop, than: EmergencyStop | None) -> bool:
    """Whether ``candidate`` supersedes ``than``: newer by stamp, or as new and engaged."""
    if than is None:
        return True
    if candidate.stamp != than.stamp:
        return candidate.stamp > than.stamp
    return candidate.engaged and not than.engaged


class EstopLatch:
    """One service's view of the stack's emergency stop (thread-safe).

    ``on_change(state)`` runs, on the thread that learned it, whenever what the service must
    do changes: from unknown to known, engaged to released or back."""

    def __init__(self, on_change: Callable[[EstopState], None] | None = None) -> None:
        self._on_change = on_change
        self._lock = threading.Lock()
        self._state = UNKNOWN
        self._heard = 0  # stops heard so far: an answer they overtook is stale
        self._asked_at = 0.0

    # --- what the service reads -------------------------------------------------------------
    @property
    def state(self) -> EstopState:
        with self._lock:
            return self._state

    @property
    def engaged(self) -> bool:
        """True while the stop is engaged *or not yet known*: either way, nothing moves."""
        return self.state.engaged

    @property
    def known(self) -> bool:
        return self.state.known

    def describe(self) -> str:
        """``estop_engaged: <reason> (by <who>)``: what a refusal because of it says."""
        state = self.state
        return stop_reason(state.reason, state.by)

    # --- what it learns ---------------------------------------------------------------------
    def heard(self, message: EmergencyStop) -> None:
        """A stop published on the bus (any Zenoh thread): applied as it arrives."""
        with self._lock:
            self._heard += 1
        self._learn(message)

    def answered(self, answers: list[EmergencyStop], heard_before: int | None = None) -> None:
        """The latch's answers to one query (several where several routers hold one).
        ``heard_before``: how many stops had been heard when the query was sent; if one has
        been heard since, the answer may be older than it and is ignored (once known)."""
        best: EmergencyStop | None = None
        for answer in answers:
            if newer(answer, best):
                best = answer
        if best is None:
            return
        with self._lock:
            stale = heard_before is not None and heard_before != self._heard and self._state.known
        if not stale:
            self._learn(best)

    def _learn(self, message: EmergencyStop) -> None:
        state = state_of(message)
        with self._lock:
            before, self._state = self._state, state
        changed = (before.engaged, before.known) != (state.engaged, state.known)
        if changed and self._on_change is not None:
            self._on_change(state)

    # --- asking the latch -------------------------------------------------------------------
    def ask(self, bus: Bus, timeout: float = 1.0) -> bool:
        """Query the stack's latch (blocking up to ``timeout``); True when it answered."""
        self._asked_at = time.monotonic()
        with self._lock:
            heard_before = self._heard
        key = bus.scoped(EmergencyStop.key)
        try:
            answers = read_answers(query_latch(bus.session, key, timeout), key)
        except zenoh.ZError as exc:  # the session is closing
            log.debug("latch query failed: %s", exc)
            return False
        self.answered(answers, heard_before)
        return bool(answers)

    def due(self, now: float) -> bool:
        """Whether it is time to ask the latch again."""
        period = REFRESH_SECONDS if self.known else UNKNOWN_RETRY_SECONDS
        return now - self._asked_at >= period


def query_latch(session: zenoh.Session, key: str, timeout: float) -> Any:
    """Ask every latch (router) that holds ``key`` at once; the replies come as they come
    (:func:`read_answers`). Several queries may be under way together."""
    return session.get(
        key,
        target=zenoh.QueryTarget.ALL,
        consolidation=zenoh.ConsolidationMode.NONE,
        timeout=timeout,
    )


def read_answers(replies: Any, key: str) -> list[EmergencyStop]:
    """The stops the latches answered with, waiting for the query to end; a forged answer
    counts for nothing."""
    answers: list[EmergencyStop] = []
    for reply in replies:
        if reply.ok is None:
            continue
        try:
            answers.append(EmergencyStop.decode(reply.ok.payload.to_bytes(), key))
        except MessageError as exc:
            log.warning("the latch's answer was refused: %s", exc)
    return answers
