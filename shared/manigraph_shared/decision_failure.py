"""A planner that cannot read an episode's world says so once, and the episode ends for it.

A policy that refuses a scene (a value its checkpoint's feature vocabulary never saw, an
entity of another task family) refuses every later scene of that episode the same way: 10 a
second, each logged, while the run client waited ``stall_timeout`` for progress and then
called the episode ``no_progress``. Instead the planner refuses the episode once: it raises
:class:`CannotDecide`, which its service logs and publishes as its error status (that is the
one message every service may publish on a secure stack), and decides nothing more in that
episode. The run client reads that status, ends the episode at once with reason
``cannot_decide: <why>`` and ends the run: the checkpoint cannot serve this task, so ``run``
and ``up --episodes`` exit with the configuration status (78), naming it.

A planner whose every option in an episode was refused by the skills (on a world that has not
changed where it matters: ``manigraph_planner.refusals``) says so the same way, with a why that
starts ``out_of_options``: that episode alone is over, so the run client ends it with reason
``out_of_options: ...`` and goes on with the next one.

The status's ``detail`` is ``cannot_decide: episode <id>: <why>``; an episode id has no
spaces (``Identifier``), so the first ``": "`` after it ends it.
"""

from __future__ import annotations

from manigraph_shared.errors import PolicyError
from manigraph_shared.messages import ServiceState, ServiceStatus

#: The reason of an episode its planner could not decide on, and the head of that status.
CANNOT_DECIDE = "cannot_decide"
_HEAD = f"{CANNOT_DECIDE}: episode "
#: The head of the why of an episode whose every option was refused (not the run's fault).
OUT_OF_OPTIONS = "out_of_options"


class CannotDecide(PolicyError):
    """The policy cannot decide on ``episode_id``'s scenes, for ``why`` (its refusal)."""

    def __init__(self, episode_id: str, why: str) -> None:
        super().__init__(f"{_HEAD}{episode_id}: {why}")
        self.episode_id = episode_id
        self.why = why


def cannot_decide(status: ServiceStatus) -> tuple[str, str] | None:
    """``(episode id, why)`` when ``status`` is an error status saying its service cannot
    decide on that episode; else None (a heartbeat repeating the last error is not one)."""
    if status.state is not ServiceState.ERROR or not status.detail.startswith(_HEAD):
        return None
    episode_id, separator, why = status.detail[len(_HEAD) :].partition(": ")
    if not separator or not episode_id or " " in episode_id:
        return None
    return episode_id, why
