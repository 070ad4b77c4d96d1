"""The planner's explain queries, answered from its recent decisions (no bus)."""

from __future__ import annotations

import threading
import time
from collections.abc import Callable

import pytest
import torch

from manigraph_planner.decisions import DecisionHistory, DecisionMaker
from manigraph_planner.explain import ExplainHandler
from manigraph_planner.gnn.models import ModelConfig, PolicyNet
from manigraph_planner.policies import load_policy
from manigraph_planner.policies.gnn import GNNPolicy
from manigraph_shared.errors import ManigraphError, MessageError, PolicyError
from manigraph_shared.messages import ExplainRequest, Explanation, Scene


@pytest.fixture
def planner(make_stack_scene: Callable[[int], Scene]) -> tuple[DecisionMaker, ExplainHandler]:
    torch.manual_seed(0)
    decisions = DecisionMaker(GNNPolicy(PolicyNet(ModelConfig("sage"))))
    return decisions, ExplainHandler(decisions.policy, decisions.history)


def test_latest_and_by_id_explain_the_decisions_the_planner_made(
    planner: tuple[DecisionMaker, ExplainHandler], make_stack_scene: Callable[[int], Scene]
) -> None:
    decisions, handler = planner
    with pytest.raises(ManigraphError, match="decision_id: the planner has made no decision"):
        handler(ExplainRequest())
    first = decisions.on_scene(make_stack_scene(4))
    assert first is not None
    decisions.pending = None  # as if its skill had ended
    second = decisions.on_scene(make_stack_scene(4).replace(stamp=2.0))
    assert second is not None and second.decision_id != first.decision_id
    latest = handler(ExplainRequest(decision_id="latest"))
    assert latest.decision_id == second.decision_id == handler(ExplainRequest()).decision_id
    older = handler(ExplainRequest(decision_id=first.decision_id))
    assert (older.decision_id, older.object, older.goal) == (
        first.decision_id,
        first.object_id,
        first.goal_id,
    )
    with pytest.raises(ManigraphError, match="decision_id: 'test:99' is not one of"):
        handler(ExplainRequest(decision_id="test:99"))


def test_a_scene_in_the_request_is_decided_on_then_explained(
    planner: tuple[DecisionMaker, ExplainHandler], make_stack_scene: Callable[[int], Scene]
) -> None:
    decisions, handler = planner
    scene = make_stack_scene(5)
    explanation = handler(ExplainRequest(scene=scene, seed=3))
    decision = decisions.policy.decide(scene)
    assert decision is not None and explanation.decision_id is None
    assert (explanation.object, explanation.goal, explanation.seed) == (
        decision.object_id,
        decision.goal_id,
        3,
    )
    assert decisions.history.latest() is None  # explaining is not deciding
    assert Explanation.decode(explanation.encode()) == explanation  # valid on the wire


def test_malformed_requests_are_refused_naming_the_field(
    make_stack_scene: Callable[[int], Scene],
) -> None:
    with pytest.raises(MessageError, match="decision_id"):
        ExplainRequest.decode(b'{"decision_id": "no spaces allowed"}')
    with pytest.raises(MessageError, match=r"scene\.objects\.0\.position\.x"):
        ExplainRequest.decode(
            b'{"scene": {"episode_id": "e", "stamp": 1, "sequence": 0, "goals": [],'
            b' "objects": [{"id": "b", "category": "block", "size": {"x": 1, "y": 1, "z": 1},'
            b' "position": {"x": "far", "y": 0, "z": 0}}]}}'
        )
    with pytest.raises(MessageError, match="decision_id: give a decision id or a scene"):
        ExplainRequest.decode(
            ExplainRequest(scene=make_stack_scene(2))
            .to_json()
            .replace('"decision_id":null', '"decision_id":"e:1"')
            .encode()
        )


def test_an_expert_planner_answers_every_request_with_a_clear_error(
    make_stack_scene: Callable[[int], Scene],
) -> None:
    handler = ExplainHandler(load_policy("expert"), DecisionHistory())
    assert not handler.available
    with pytest.raises(PolicyError, match="only GNN policies can be explained"):
        handler(ExplainRequest(scene=make_stack_scene(3)))


def test_the_history_keeps_only_the_last_decisions(
    planner: tuple[DecisionMaker, ExplainHandler], make_stack_scene: Callable[[int], Scene]
) -> None:
    decisions, _ = planner
    history = DecisionHistory(capacity=2)
    decisions.history = history
    ids = []
    for step in range(3):
        decisions.pending = None
        action = decisions.on_scene(make_stack_scene(3).replace(stamp=1.0 + step))
        assert action is not None
        ids.append(action.decision_id)
    assert history.ids() == ids[1:]
    assert history.get(ids[0]) is None
    with pytest.raises(ValueError, match="capacity"):
        DecisionHistory(capacity=0)


def test_a_query_while_the_explainer_warms_up_is_refused_at_once_then_answered(
    planner: tuple[DecisionMaker, ExplainHandler],
    make_stack_scene: Callable[[int], Scene],
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """The planner builds its explainer on a thread of its own; a query meanwhile gets
    ``explainer_warming_up`` (the client asks again) instead of waiting for the build."""
    from manigraph_planner.explain.scene_explainer import SceneExplainer

    _, handler = planner
    release, warming = threading.Event(), threading.Event()
    warm_up = SceneExplainer.warm_up

    def slow_warm_up(self: SceneExplainer) -> None:
        warming.set()
        release.wait(30)
        warm_up(self)

    monkeypatch.setattr(SceneExplainer, "warm_up", slow_warm_up)
    builder = threading.Thread(target=handler.prepare)
    builder.start()
    try:
        assert warming.wait(30)
        started = time.monotonic()
        with pytest.raises(PolicyError, match=r"^explainer_warming_up: "):
            handler(ExplainRequest(scene=make_stack_scene(3)))
        assert time.monotonic() - started < 5  # refused, not held until the build ends
    finally:
        release.set()
        builder.join(30)
    assert handler(ExplainRequest(scene=make_stack_scene(3))).object
