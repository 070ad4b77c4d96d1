"""A reset the sim refuses ends the querier's query with the error reply, not at its timeout."""

from __future__ import annotations

import time

import pytest

from manigraph_shared.messages import EpisodeRequest
from manigraph_testkit.testing import Stack

pytestmark = pytest.mark.integration

#: Far above what a refusal takes, far below the query timeout below: a query still open
#: after this long is one that ends only at its timeout (or when the garbage collector runs).
WELL_UNDER = 5.0
QUERY_TIMEOUT = 30.0


@pytest.mark.parametrize(
    "request_",
    [
        EpisodeRequest(episode_id="e-1", task="no_such_task"),
        EpisodeRequest(episode_id="e-2", task="file", task_file="objects = [ this is not toml"),
    ],
    ids=["unknown-task", "bad-task-file"],
)
def test_a_refused_reset_query_ends_with_its_error_reply(
    running_stack: Stack, request_: EpisodeRequest
) -> None:
    running_stack.start("router")
    running_stack.start("sim", "sim", "--backend", "geometric")
    with running_stack.client() as bus:
        running_stack.wait_alive(bus, "sim")
        for attempt in range(3):  # the query of a refusal must end every time, not once
            started = time.monotonic()
            replies = bus.session.get(
                bus.scoped(EpisodeRequest.key), payload=request_.encode(), timeout=QUERY_TIMEOUT
            )
            errors = [r.err.payload.to_string() for r in replies if r.err is not None]
            ended = time.monotonic() - started  # the iteration ends when the query does
            assert len(errors) == 1, errors
            assert ended < WELL_UNDER, (
                f"attempt {attempt}: the error reply came but the query ended after {ended:.1f} s"
            )


def test_a_stack_started_with_a_task_file_refuses_another_task_naming_it(
    running_stack: Stack,
) -> None:
    running_stack.start("router")
    running_stack.start("sim", "sim", "--backend", "geometric", "--plays", "colour-place.toml")
    with running_stack.client() as bus:
        running_stack.wait_alive(bus, "sim")
        request_ = EpisodeRequest(episode_id="e-3", task="stack")
        replies = bus.session.get(
            bus.scoped(EpisodeRequest.key), payload=request_.encode(), timeout=QUERY_TIMEOUT
        )
        errors = [r.err.payload.to_string() for r in replies if r.err is not None]
        assert len(errors) == 1 and "this stack plays colour-place.toml" in errors[0], errors
        assert "--task-file colour-place.toml" in errors[0]
