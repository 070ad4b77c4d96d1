"""The decision the skills worker is executing, and whether its final status has gone out.

The emergency stop must be answered within 100 ms whatever the worker is doing: waiting for
a scene, planning (IK and collision re-plans take hundreds of milliseconds, seconds on a
loaded machine), or inside a driver call. So the thread that delivers the stop reports the
decision under way as failed with reason ``stopped`` itself (:meth:`ActionInFlight.stop`),
after the driver was told to halt, and whatever the worker reports for that decision later
is dropped: every decision gets exactly one final status, and nothing after it.
"""

from __future__ import annotations

import threading
import time
from collections.abc import Callable

from manigraph_shared.messages import SkillState, SkillStatus


class ActionInFlight:
    def __init__(self, publish: Callable[[SkillStatus], None], skill: str) -> None:
        self._publish = publish
        self._skill = skill
        self._lock = threading.Lock()
        self._decision: str | None = None
        self._finished = False

    def begin(self, decision_id: str) -> None:
        """The worker starts on ``decision_id``."""
        with self._lock:
            self._decision, self._finished = decision_id, False

    @property
    def under_way(self) -> bool:
        """Whether the worker is on a decision that has no final status yet."""
        with self._lock:
            return self._decision is not None and not self._finished

    def end(self) -> None:
        """The worker is done with the decision (whatever it reported)."""
        with self._lock:
            self._decision = None

    def report(self, status: SkillStatus) -> None:
        """Publish the worker's ``status`` unless its decision already has a final one.

        Published under the lock, so a stop cannot slip its final status in between."""
        with self._lock:
            if status.decision_id == self._decision:
                if self._finished:
                    return
                self._finished = status.state.terminal
            self._publish(status)

    def stop(self, detail: str) -> str | None:
        """Fail the decision under way with reason ``stopped`` now; its decision id, or None
        when the worker is idle or the decision already ended."""
        with self._lock:
            if self._decision is None or self._finished:
                return None
            self._finished = True
            self._publish(
                SkillStatus(
                    decision_id=self._decision,
                    skill=self._skill,
                    state=SkillState.FAILED,
                    reason="stopped",
                    detail=detail[:1024],
                    stamp=time.time(),
                )
            )
            return self._decision
