"""A rule that pairs an object with a goal: the ``pairs`` decoder learns it, the paper's
two independent softmaxes cannot; the trained pair policy ranks, explains and saves."""

from __future__ import annotations

from pathlib import Path

import pytest
import torch

from manigraph_planner.explain import SceneExplainer
from manigraph_planner.gnn.checkpoint import load_checkpoint
from manigraph_planner.gnn.features import FeatureSpec, scene_to_graph
from manigraph_planner.gnn.task_features import TaskFeatures
from manigraph_planner.policies.gnn import GNNPolicy
from manigraph_shared.messages import Scene, SceneGoal, SceneObject, Vector3
from manigraph_training.dataset import Demonstrations, Sample
from manigraph_training.recipes import augmentation_for
from manigraph_training.trainer import TrainConfig, train

SIZE = Vector3(x=0.04, y=0.04, z=0.04)
CHECKPOINTS = Path(__file__).resolve().parents[2] / "checkpoints"


def bins_scene(bin_colours: tuple[str, str]) -> Scene:
    """A red and a blue block; two bins whose colours are ``bin_colours``, left to right."""
    objects = [
        SceneObject(
            id=f"b{i}",
            category="block",
            position=Vector3(x=0.4, y=-0.1 + 0.2 * i, z=0.02),
            size=SIZE,
            attributes={"colour": colour},
        )
        for i, colour in enumerate(["red", "blue"])
    ]
    goals = [
        SceneGoal(
            id=f"bin{i}",
            category="block",
            position=Vector3(x=0.6, y=-0.1 + 0.2 * i, z=0.02),
            attributes={"colour": colour},
        )
        for i, colour in enumerate(bin_colours)
    ]
    return Scene(episode_id="t", stamp=1.0, sequence=0, objects=objects, goals=goals)


SCENES = (bins_scene(("red", "blue")), bins_scene(("blue", "red")))


def matching(scene: Scene) -> set[tuple[str, str]]:
    colour = {o.id: o.attributes["colour"] for o in scene.objects}
    return {(o, g.id) for o in colour for g in scene.goals if g.attributes["colour"] == colour[o]}


def same_colour_demos() -> Demonstrations:
    """Each scene demonstrated twice, once per block (which block goes first is the teacher's
    own, invisible order), each block into the bin of its colour."""
    spec = FeatureSpec.for_task(TaskFeatures.learn(list(SCENES)))
    samples = []
    for scene in SCENES:
        graph = scene_to_graph(scene, spec)
        for object_id, goal_id in sorted(matching(scene)):
            samples.append(
                Sample(
                    graph.x,
                    graph.is_object,
                    graph.object_ids.index(object_id),
                    graph.num_objects + graph.goal_ids.index(goal_id),
                )
            )
    return Demonstrations(samples, "hash", len(samples), 0, spec)


def trained(decoder: str) -> GNNPolicy:
    config = TrainConfig(
        architecture="sage",
        epochs=150,
        learning_rate=0.03,
        hidden_channels=16,
        decoder=decoder,
        augmentation=augmentation_for("sage", 2),
    )
    net, _ = train(same_colour_demos(), config)
    return GNNPolicy(net)


def matching_mass(policy: GNNPolicy, scene: Scene) -> float:
    """The probability the policy's decoder gives the pairs of the same colour."""
    graph = policy.graph(scene)
    k = graph.num_objects
    if policy.net.decodes_pairs:
        joint = policy.pair_scores(graph)[0].exp()
    else:
        logits = policy.node_logits(graph)
        joint = logits[:k].softmax(0).unsqueeze(1) * logits[k:].softmax(0).unsqueeze(0)
    pairs = matching(scene)
    return sum(
        float(joint[o, g])
        for o in range(k)
        for g in range(len(graph.goal_ids))
        if (graph.object_ids[o], graph.goal_ids[g]) in pairs
    )


@pytest.fixture(scope="module")
def pair_policy() -> GNNPolicy:
    return trained("pairs")


def test_pairs_learn_the_goal_given_the_object_where_two_softmaxes_cannot(
    pair_policy: GNNPolicy,
) -> None:
    nodes = trained("nodes")
    for scene in SCENES:
        # the independent softmaxes put 1/2 on each block and each bin: 1/2 on same colour
        assert matching_mass(nodes, scene) < 0.7
        assert matching_mass(pair_policy, scene) > 0.9
        decision = pair_policy.decide(scene)
        assert decision is not None
        assert (decision.object_id, decision.goal_id) in matching(scene)


def test_ranked_lists_every_pair_by_joint_probability_the_decision_first(
    pair_policy: GNNPolicy,
) -> None:
    for scene in SCENES:
        ranked = pair_policy.ranked(scene)
        assert len(ranked) == 4 and ranked[0] == pair_policy.decide(scene)
        assert {(d.object_id, d.goal_id) for d in ranked[:2]} == matching(scene)
        probs = pair_policy.probabilities(scene)
        assert float(probs.object_probs.sum()) == pytest.approx(1.0, abs=1e-5)
        assert float(probs.goal_probs.sum()) == pytest.approx(1.0, abs=1e-5)


def test_the_explainer_explains_the_chosen_pair(pair_policy: GNNPolicy) -> None:
    scene = SCENES[0]
    decision = pair_policy.decide(scene)
    assert decision is not None
    explanation = SceneExplainer(pair_policy).explain_scene(scene, seed=0)
    assert (explanation.object, explanation.goal) == (decision.object_id, decision.goal_id)
    assert 0.0 <= explanation.fidelity <= 1.0
    other_bin = next(g.id for g in scene.goals if g.id != decision.goal_id)
    assert other_bin in explanation.sentence  # the rival goal for the chosen block


@pytest.mark.parametrize("name", ["sage.pt", "gat.pt", "gcn.pt", "gated.pt"])
def test_shipped_checkpoints_load_as_node_decoders_with_their_own_weights(name: str) -> None:
    stored = torch.load(CHECKPOINTS / name, weights_only=True)
    net, info = load_checkpoint(CHECKPOINTS / name, message_passing=False)
    assert "decoder" not in stored["model"] and info.model.decoder == "nodes"
    assert not net.decodes_pairs and set(net.state_dict()) == set(stored["state_dict"])
