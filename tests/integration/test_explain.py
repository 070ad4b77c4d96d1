"""`manigraph explain` against a real stack: router, sim, GNN planner, skills on loopback."""

from __future__ import annotations

import json
import shutil
import threading
import time
from pathlib import Path

import pytest

from manigraph_shared.errors import CONFIG_EXIT_CODE, RUNTIME_EXIT_CODE, PolicyError
from manigraph_shared.messages import Action, ExplainRequest, Explanation
from manigraph_testkit.testing import Stack

pytestmark = pytest.mark.integration

CHECKPOINT = Path(__file__).resolve().parents[2] / "checkpoints" / "sage.pt"


def last_json(output: str) -> dict[str, object]:
    return json.loads(output.strip().splitlines()[-1])


def test_explain_answers_for_the_latest_decision_and_refuses_bad_queries_quickly(
    running_stack: Stack, tmp_path: Path
) -> None:
    if not CHECKPOINT.is_file():
        pytest.skip(f"no shipped checkpoint {CHECKPOINT}")
    policy = shutil.copy(CHECKPOINT, tmp_path / "policy.pt")  # immune to retraining mid-test
    running_stack.start("router")
    running_stack.start("sim", "sim")
    running_stack.start("planner", "planner", "--policy", str(policy), "--explain-decisions")
    running_stack.start("skills", "skills")
    actions: list[Action] = []
    published: list[Explanation] = []
    lock = threading.Lock()

    def keep(into: list) -> object:  # type: ignore[type-arg]
        def add(message: object) -> None:
            with lock:
                into.append(message)

        return add

    with running_stack.client() as bus:
        # A GNN planner loads torch and its checkpoint first: give it time on a busy machine.
        running_stack.wait_alive(bus, "router", "sim", "planner", "skills", timeout=120)
        bus.subscribe(Action, keep(actions))  # type: ignore[arg-type]
        bus.subscribe(Explanation, keep(published))  # type: ignore[arg-type]
        time.sleep(0.3)
        result = running_stack.run("run", "--task", "stack", "--blocks", "3", "--episodes", "1")
        assert result.returncode == 0, result.stderr[-3000:] + running_stack.log("planner")
        assert actions, "the planner decided nothing"

        # The CLI: the latest decision, as one JSON object on the last line.
        png = tmp_path / "why.png"
        answer = running_stack.run("explain", "--json", "--png", str(png), timeout=60)
        assert answer.returncode == 0, answer.stderr[-3000:] + running_stack.log("planner")
        explained = last_json(answer.stdout)
        assert set(explained) >= {"decision_id", "object", "goal", "edges", "features", "sentence"}
        latest = actions[-1]
        assert explained["decision_id"] == latest.decision_id
        assert (explained["object"], explained["goal"]) == (latest.object_id, latest.goal_id)
        edges = explained["edges"]
        assert isinstance(edges, list) and 1 <= len(edges) <= 3
        assert all({"src", "dst", "weight"} <= set(edge) for edge in edges)
        assert set(explained["features"]) == {"category", "x", "y", "z", "filled"}  # type: ignore[arg-type]
        assert str(explained["sentence"]).startswith(f"{latest.object_id} was chosen")
        assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"

        # One decision by id, straight over the bus, well inside the query timeout.
        first = actions[0]
        started = time.monotonic()
        reply = bus.request(ExplainRequest(decision_id=first.decision_id), Explanation, 4.0)
        assert time.monotonic() - started < 4.0  # well inside the 5 s query timeout
        assert (reply.decision_id, reply.object, reply.goal) == (
            first.decision_id,
            first.object_id,
            first.goal_id,
        )

        # Bad queries: error replies, at once (never the 5 s timeout), and it keeps serving.
        refused = running_stack.run("explain", "--decision", "nope:7", "--json", timeout=60)
        assert refused.returncode == CONFIG_EXIT_CODE  # refused: asking again fails again
        assert "decision_id: 'nope:7' is not one of" in refused.stderr
        unknown = ExplainRequest(decision_id="nope:8").encode()
        for payload in (unknown, b'{"scene": {"episode_id": "e"}}', b"not json", b'{"seed": -1}'):
            started = time.monotonic()
            replies = list(bus.session.get(ExplainRequest.key, payload=payload, timeout=5.0))
            assert time.monotonic() - started < 2.0, payload
            assert len(replies) == 1 and replies[0].err is not None, payload
            error = replies[0].err.payload.to_string()
            assert "decision_id: 'nope:8'" in error or "bad manigraph.ExplainRequest" in error
        assert bus.request(ExplainRequest(), Explanation, 4.0).decision_id == latest.decision_id

        # --explain-decisions: one explanation beside every decision (so it lands in the log).
        deadline = time.monotonic() + 5.0
        while time.monotonic() < deadline and len(published) < len(actions):
            time.sleep(0.05)
        with lock:
            assert [e.decision_id for e in published] == [a.decision_id for a in actions]


def test_explain_without_a_planner_fails_with_a_clear_message(running_stack: Stack) -> None:
    running_stack.start("router")
    with running_stack.client() as bus:
        running_stack.wait_alive(bus, "router")
    result = running_stack.run("explain", "--json", "--timeout", "1", timeout=60)
    assert result.returncode == RUNTIME_EXIT_CODE  # nobody answered: later may work
    assert "no answer within 1.0 s" in result.stderr


def test_explain_asks_again_while_the_explainer_is_busy(running_stack: Stack) -> None:
    """A planner explaining every decision is busy with the last one just when a person asks
    (a CI run under load got ``explainer_busy`` from a planner so), and one just started may
    still warm its explainer up: the CLI asks again until its timeout. Here a queryable on the
    real router is warming up, then busy, then answers."""
    running_stack.start("router")
    asked: list[float] = []

    def busy_twice(request: ExplainRequest) -> Explanation:
        asked.append(time.monotonic())
        if request.decision_id == "nope:1":
            raise PolicyError("decision_id: 'nope:1' is not one of the planner's decisions")
        if len(asked) == 1:
            raise PolicyError("explainer_warming_up: the explainer is being built; ask again")
        if len(asked) == 2:
            raise PolicyError("explainer_busy: one explanation at a time; ask again later")
        return Explanation(
            decision_id="e:0", episode_id="e", scene_sequence=1, policy="gnn-sage",
            object="block_0", goal="goal_0", edges=[], features={}, nodes=[],
            sentence="block_0 was chosen", fidelity=1.0, seed=0, stamp=time.time(),
        )  # fmt: skip

    with running_stack.client() as planner:
        planner.serve(ExplainRequest, busy_twice)
        answer = running_stack.run("explain", "--json", "--timeout", "4", timeout=60)
        assert answer.returncode == 0, answer.stderr
        assert last_json(answer.stdout)["decision_id"] == "e:0"
        assert len(asked) == 3
        refused = running_stack.run("explain", "--decision", "nope:1", "--json", timeout=60)
        assert refused.returncode == CONFIG_EXIT_CODE and "'nope:1' is not one of" in refused.stderr
        assert len(asked) == 4  # any other refusal is final: asked once
