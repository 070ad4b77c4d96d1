"""Why did the planner decide that? Ask the running planner over Zenoh
(:func:`explain_online`), or explain a decision recorded in a log with a checkpoint
(:func:`explain_offline`); ``manigraph explain`` prints and draws the answer."""

from __future__ import annotations

import time
from pathlib import Path

from manigraph_shared.bus_config import BusConfig
from manigraph_shared.errors import LogError
from manigraph_shared.messages import (
    EXPLAINER_BUSY,
    EXPLAINER_WARMING_UP,
    Action,
    ExplainRequest,
    Explanation,
    Scene,
)


def summary(explanation: Explanation) -> dict[str, object]:
    """The CLI's JSON: decision_id, object, goal, edges, features, sentence (and a bit more)."""
    data = explanation.to_builtins()
    keys = ("decision_id", "object", "goal", "edges", "features", "sentence")
    extra = ("episode_id", "scene_sequence", "policy", "fidelity", "seed")
    return {key: data[key] for key in (*keys, *extra)}


#: The planner's refusals that pass: asked again until the timeout.
RETRIED = (EXPLAINER_BUSY, EXPLAINER_WARMING_UP)


def explain_online(
    config: BusConfig, decision: str | None, seed: int, timeout: float
) -> Explanation:
    """The planner's answer on ``manigraph/planner/explain`` within ``timeout`` seconds;
    BusError on error replies. A planner that explains every decision is often busy with the
    last one just when a person asks, and a planner just started may still be building its
    explainer: ``explainer_busy`` and ``explainer_warming_up`` are asked again, a little later
    each time, until ``timeout`` has passed (then that refusal is the error)."""
    from manigraph_shared.bus import Bus
    from manigraph_shared.errors import RequestRefused

    request = ExplainRequest(decision_id=decision, seed=seed)
    deadline = time.monotonic() + timeout
    pause = 0.1
    with Bus.open(config) as bus:
        while True:
            left = deadline - time.monotonic()
            try:
                return bus.request(request, Explanation, timeout=max(left, 0.1))
            except RequestRefused as exc:
                again = any(code in str(exc) for code in RETRIED)
                if not again or time.monotonic() + pause >= deadline:
                    raise
            time.sleep(pause)
            pause = min(pause * 2, 0.5)


def explain_offline(
    checkpoint: Path, log: Path, decision: str | None, seed: int
) -> tuple[Explanation, str]:
    """Explain what ``checkpoint`` decides on the scene of a decision recorded in ``log``
    (``decision``, or the last one; without recorded decisions, the log's last scene).

    Returns the explanation and a note, non-empty when the log recorded another choice (e.g.
    the expert's) than the checkpoint makes: the checkpoint's own choice is the one explained.
    """
    from manigraph_planner.explain import SceneExplainer
    from manigraph_planner.policies.gnn import GNNPolicy
    from manigraph_shared.mcap_log import read_log

    if not log.is_file():
        raise LogError(f"scene-from: no such file: {log}")
    scenes: dict[tuple[str, int], Scene] = {}
    actions: list[Action] = []
    last_scene: Scene | None = None
    for item in read_log(log, [Scene.key, Action.key]):
        message = item.decode()
        if isinstance(message, Scene):
            scenes[(message.episode_id, message.sequence)] = last_scene = message
        elif isinstance(message, Action):
            actions.append(message)
    explainer = SceneExplainer(GNNPolicy.from_checkpoint(checkpoint))
    if decision is not None:
        actions = [a for a in actions if a.decision_id == decision]
        if not actions:
            raise LogError(f"decision: '{decision}' is not a decision recorded in {log}")
    if not actions:
        if last_scene is None:
            raise LogError(f"scene-from: {log} holds no scene")
        return explainer.explain_scene(last_scene, seed), ""
    action = actions[-1]
    scene = scenes.get((action.episode_id, action.scene_sequence))
    if scene is None:
        raise LogError(f"decision: the scene of '{action.decision_id}' is not in {log}")
    own = explainer.explain_scene(scene, seed).replace(decision_id=action.decision_id)
    note = ""
    if (own.object, own.goal) != (action.object_id, action.goal_id):
        note = (
            f"note: the log recorded {action.object_id} -> {action.goal_id} "
            f"({action.policy}); {own.policy} chooses {own.object} -> {own.goal} on that "
            "scene, which is what is explained"
        )
    return own, note
