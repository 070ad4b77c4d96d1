"""Failures a user must see, each once and with the exit status of its kind
(docs/running.md, "Exit codes"), over a real router with stand-ins for the services."""

from __future__ import annotations

import contextlib
import json
import time
from collections.abc import Callable, Iterator

import pytest

from manigraph_shared.bus import Bus
from manigraph_shared.decision_failure import CannotDecide
from manigraph_shared.errors import (
    CONFIG_EXIT_CODE,
    RUNTIME_EXIT_CODE,
    BusError,
    RequestFailed,
    RequestRefused,
    TaskError,
)
from manigraph_shared.messages import EpisodeEvent, EpisodeRequest, ServiceStatus
from manigraph_testkit.testing import Stack

pytestmark = pytest.mark.integration

REQUEST = EpisodeRequest(episode_id="loud-0", task="stack", blocks=2)


def started(request: EpisodeRequest) -> EpisodeEvent:
    return EpisodeEvent(
        episode_id=request.episode_id,
        phase="start",
        task=request.task,
        seed=request.seed,
        goals_total=2,
        goals_filled=0,
        stamp=1.0,
    )


@contextlib.contextmanager
def stand_in_stack(
    running: Stack, reset: Callable[[EpisodeRequest], EpisodeEvent]
) -> Iterator[Bus]:
    """A router, and one session playing sim, planner and skills: alive, answering resets
    with ``reset``."""
    running.start("router")
    with running.client() as services:
        services.serve(EpisodeRequest, reset)
        for name in ("sim", "planner", "skills"):
            services.declare_alive(name)
        yield services


def test_an_error_reply_carries_its_kind(running_stack: Stack) -> None:
    """A queryable's runtime error is raised as one at the querier (exit 1), a refusal as a
    refusal (exit 78): the text alone does not say which."""

    def reset(request: EpisodeRequest) -> EpisodeEvent:
        if request.seed == 1:
            raise BusError("reset_timeout: not done within 30 s")
        raise TaskError("objects.0.category: 'ball' is not one of ...")

    with stand_in_stack(running_stack, reset), running_stack.client() as client:
        with pytest.raises(RequestFailed, match="reset_timeout") as failed:
            client.request(EpisodeRequest(episode_id="e", task="stack", seed=1), EpisodeEvent)
        assert failed.value.exit_code == RUNTIME_EXIT_CODE
        with pytest.raises(RequestRefused, match=r"objects\.0\.category") as refused:
            client.request(EpisodeRequest(episode_id="e", task="stack"), EpisodeEvent)
        assert type(refused.value) is RequestRefused
        assert refused.value.exit_code == CONFIG_EXIT_CODE


def test_a_reset_timeout_ends_run_with_the_runtime_status_naming_it(
    running_stack: Stack,
) -> None:
    def reset(request: EpisodeRequest) -> EpisodeEvent:  # as the sim's, cut off at once
        raise BusError("reset_timeout: the reset was not done within 30 s (the sim is busy)")

    with stand_in_stack(running_stack, reset):
        result = running_stack.run("run", "--episodes", "1", "-e", running_stack.endpoint)
    assert result.returncode == RUNTIME_EXIT_CODE, result.stderr  # was 78: "refused"
    last = result.stderr.strip().splitlines()[-1]
    assert last.startswith("manigraph run: ") and "reset_timeout: " in last, result.stderr


def test_a_planner_that_cannot_decide_ends_the_episode_and_run_at_once(
    running_stack: Stack,
) -> None:
    """The planner says once that it cannot read the episode (its error status): the client
    ends the episode with that reason at once, not ``no_progress`` after the stall timeout,
    and the run with the configuration status naming it."""
    why = "scene: block 'b0' colour 'mauve' is not in this policy's vocabulary (blue, red)"
    holder: dict[str, Bus] = {}

    def reset(request: EpisodeRequest) -> EpisodeEvent:
        refusal = CannotDecide(request.episode_id, why)
        holder["bus"].publish(
            ServiceStatus(service="planner", state="error", detail=str(refusal), stamp=1.0)
        )
        return started(request)

    with stand_in_stack(running_stack, reset) as services:
        holder["bus"] = services
        started_at = time.monotonic()
        result = running_stack.run(
            "run", "--episodes", "3", "--stall-timeout", "30", "-e", running_stack.endpoint
        )
        seconds = time.monotonic() - started_at
    assert result.returncode == CONFIG_EXIT_CODE, result.stderr
    assert result.stderr.strip().splitlines()[-1] == f"manigraph run: cannot_decide: {why}"
    summary = json.loads(result.stdout.strip().splitlines()[-1])
    assert summary["episodes"] == 1 and summary["aborted"] == f"cannot_decide: {why}"
    assert seconds < 25  # not the 30 s stall timeout (a run client starts in ~2 s)
