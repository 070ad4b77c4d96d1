"""Structural augmentation never changes what the expert would decide (checked by the expert)."""

from __future__ import annotations

import pytest
import torch

from manigraph_blocks.planner.expert import ExpertPolicy
from manigraph_blocks.training.augment import Augmentation
from manigraph_blocks.training.structure import (
    BLOCK,
    COVER,
    DemoWorldSizes,
    Graph,
    add_distractors,
    add_finished_tower,
    add_open_box,
    drop_finished_pairs,
    drop_idle_covers,
    extend_towers,
    hide_box_contents,
    is_closing,
    open_box_contents,
)
from manigraph_lab.demo_recording import DemoProtocol, record_demos
from manigraph_planner.policies import load_policy
from manigraph_shared.messages import Scene, SceneGoal, SceneObject, Vector3
from manigraph_training.dataset import Sample, load_demonstrations

GEOMETRY = DemoWorldSizes()
SIZES = {COVER: (0.16, 0.16, 0.01), BLOCK: (0.04, 0.04, 0.04)}


@pytest.fixture(scope="module")
def samples(tmp_path_factory: pytest.TempPathFactory) -> list[Sample]:
    path = tmp_path_factory.mktemp("demos") / "demos.mcap"
    record_demos(load_policy("expert"), DemoProtocol(trajectories=8), path, progress=None)  # type: ignore[arg-type]
    return load_demonstrations([path]).samples


def as_scene(x: torch.Tensor) -> Scene:
    """Node rows back into a Scene the expert can read (ids are node indices)."""
    objects, goals = [], []
    for i, (code, px, py, pz, filled) in enumerate(x.tolist()):
        position = Vector3(x=px, y=py, z=pz)
        if int(code) in SIZES:
            sx, sy, sz = SIZES[int(code)]
            objects.append(
                SceneObject(
                    id=f"n{i}",
                    category="cover" if int(code) == COVER else "block",
                    position=position,
                    size=Vector3(x=sx, y=sy, z=sz),
                    filled=bool(filled),
                )
            )
        else:
            category = "block" if int(code) == 2 else "cover"
            goals.append(
                SceneGoal(id=f"n{i}", category=category, position=position, filled=bool(filled))
            )
    return Scene(episode_id="aug", stamp=1.0, sequence=0, objects=objects, goals=goals)


def assert_expert_agrees(graph: Graph) -> None:
    """The expert picks the labelled nodes, or nodes it cannot tell apart from them."""
    decision = ExpertPolicy().decide(as_scene(graph.x))
    assert decision is not None
    chosen = (int(decision.object_id[1:]), int(decision.goal_id[1:]))
    for picked, label in zip(chosen, (graph.object_index, graph.goal_index), strict=True):
        same = graph.x[picked, [0, 3, 4]] - graph.x[label, [0, 3, 4]]
        assert bool(same.abs().max() < 1e-5), (picked, label, graph.x)


def as_graph(sample: Sample) -> Graph:
    return Graph(sample.x, sample.object_index, sample.goal_index)


def test_the_expert_agrees_with_its_own_demonstrations(samples: list[Sample]) -> None:
    for sample in samples:
        assert_expert_agrees(as_graph(sample))


@pytest.mark.parametrize("levels", [(1, 0, 0), (0, 3, 1), (0, 0, 5), (7, 11, 13)])
def test_taller_towers_keep_the_label(samples: list[Sample], levels: tuple[int, int, int]) -> None:
    grown = 0
    for sample in samples:
        graph = extend_towers(as_graph(sample), *levels, GEOMETRY)
        grown += graph.x.shape[0] > sample.x.shape[0]
        assert_expert_agrees(graph)
    assert grown >= len(samples) // 3  # pack towers and unpack goal stacks both grew


def test_no_finished_goal_stack_grows_beside_blocks_on_a_box_floor(
    samples: list[Sample],
) -> None:
    unpacking = [
        s for s in samples if int(s.x[s.object_index, 0]) == BLOCK and s.x[s.object_index, 3] < 0.03
    ]
    assert unpacking
    for sample in unpacking:
        graph = extend_towers(as_graph(sample), 0, 5, 0, GEOMETRY)
        assert int((graph.x[:, 4] == 1.0).sum()) == int((sample.x[:, 4] == 1.0).sum())


def test_a_source_tower_grows_under_its_top_block(samples: list[Sample]) -> None:
    pack = next(s for s in samples if int(s.x[s.object_index, 0]) == BLOCK and s.x.shape[0] > 8)
    graph = extend_towers(as_graph(pack), 5, 0, 0, GEOMETRY)
    top = graph.x[graph.object_index]
    column = (graph.x[:, 1:3] - top[1:3]).abs().max(dim=1).values < 1e-6
    assert int(column.sum()) >= 6
    assert float(top[3]) == pytest.approx(float(graph.x[column, 3].max()))


@pytest.mark.parametrize("box, storage", [(True, False), (False, True), (True, True)])
def test_distractors_keep_the_label(samples: list[Sample], box: bool, storage: bool) -> None:
    generator = torch.Generator().manual_seed(0)
    added = 0
    for sample in samples:
        graph = add_distractors(as_graph(sample), box, storage, generator, GEOMETRY)
        added += graph.x.shape[0] > sample.x.shape[0]
        assert_expert_agrees(graph)
    opening = sum(
        int(s.x[s.object_index, 0]) == COVER and float(s.x[s.object_index, 3]) > 0.04
        for s in samples
    )
    assert added == (len(samples) - opening if not storage else len(samples))


def test_an_open_box_elsewhere_keeps_the_label(samples: list[Sample]) -> None:
    generator = torch.Generator().manual_seed(1)
    added = 0
    for sample in samples:
        graph = add_open_box(as_graph(sample), generator, GEOMETRY)
        if graph.x.shape[0] > sample.x.shape[0]:  # else no free site on the table
            added += 1
            assert graph.x.shape[0] == sample.x.shape[0] + 3  # a stored cover, its place, a lid
        assert_expert_agrees(graph)
    assert added >= len(samples) // 2


def test_an_opening_expert_can_be_shown_an_open_box_with_blocks_or_goals(
    samples: list[Sample],
) -> None:
    generator = torch.Generator().manual_seed(3)
    shown = {"blocks": 0, "goals": 0}
    for sample in samples:
        graph = as_graph(sample)
        allowed = open_box_contents(graph, GEOMETRY)
        # Hiding the box's contents (the label is the expert's on the whole scene) leaves
        # the same choice: only what lies outside the box being opened counts.
        assert open_box_contents(hide_box_contents(graph, GEOMETRY), GEOMETRY) == allowed
        for kind in ("blocks", "goals"):
            count = {"loose_blocks": 4} if kind == "blocks" else {"free_goals": 4}
            edited = add_open_box(graph, generator, GEOMETRY, **count)
            if edited.x.shape[0] == graph.x.shape[0]:
                continue  # no free site on the table
            if kind in allowed:
                assert edited.x.shape[0] == graph.x.shape[0] + 3 + 4
                assert_expert_agrees(edited)
                shown[kind] += 1
            elif allowed:
                # The other kind would hand the expert a block to move: the guard matters.
                decision = ExpertPolicy().decide(as_scene(edited.x))
                assert decision is not None
                assert int(edited.x[int(decision.object_id[1:]), 0]) == BLOCK
    assert shown["blocks"] and shown["goals"]
    closing = next(as_graph(s) for s in samples if is_closing(as_graph(s), GEOMETRY))
    assert open_box_contents(closing, GEOMETRY) == ()


def test_a_closing_expert_can_be_shown_a_second_closed_box(samples: list[Sample]) -> None:
    generator = torch.Generator().manual_seed(2)
    closing = [as_graph(s) for s in samples if is_closing(as_graph(s), GEOMETRY)]
    assert closing
    for graph in closing:
        for packed in (0, 4):
            shown = add_distractors(graph, True, False, generator, GEOMETRY, packed)
            covers_on_boxes = (shown.x[:, 0] == COVER) & (shown.x[:, 3] > 0.04)
            assert int(covers_on_boxes.sum()) == 1  # the distractor's; the expert's is stored
            assert shown.x.shape[0] == graph.x.shape[0] + 2 + 2 * packed

            def on_a_floor(x: torch.Tensor) -> int:
                blocks = x[(x[:, 0] == BLOCK) & (x[:, 4] == 1.0)]
                return int(((blocks[:, 3] - 0.02).abs() < 1e-6).sum())

            assert on_a_floor(shown.x) == on_a_floor(graph.x) + packed
            assert_expert_agrees(shown)


def test_hiding_a_closed_box_removes_exactly_what_it_holds(samples: list[Sample]) -> None:
    hidden = 0
    for sample in samples:
        graph = as_graph(sample)
        shown = hide_box_contents(graph, GEOMETRY)
        chosen = sample.x[sample.object_index]
        opening = int(chosen[0]) == COVER and float(chosen[3]) > 0.04
        if not opening:
            assert shown is graph
            continue
        hidden += 1
        inside = (sample.x[:, 1:3] - chosen[1:3]).abs().max(dim=1).values < 0.09
        held = inside & (sample.x[:, 0] != COVER) & (sample.x[:, 0] != 3)
        assert shown.x.shape[0] == sample.x.shape[0] - int(held.sum())
        assert not bool(
            ((shown.x[:, 1:3] - chosen[1:3]).abs().max(dim=1).values < 0.09)[
                (shown.x[:, 0] == BLOCK) | (shown.x[:, 0] == 2)
            ].any()
        )
        # the label is the expert's choice on the whole scene: the same cover and place
        assert torch.equal(shown.x[shown.object_index], chosen)
        assert torch.equal(shown.x[shown.goal_index], sample.x[sample.goal_index])
    assert hidden > 0


def test_a_finished_tower_elsewhere_keeps_the_label(samples: list[Sample]) -> None:
    generator = torch.Generator().manual_seed(3)
    added = 0
    for sample in samples:
        graph = add_finished_tower(as_graph(sample), 7, generator, GEOMETRY)
        if graph is not as_graph(sample) and graph.x.shape[0] > sample.x.shape[0]:
            added += 1
            assert int(sample.x[sample.object_index, 0]) == BLOCK
            new = graph.x[graph.x[:, 4] == 1.0]
            assert float(new[:, 3].max()) == pytest.approx(0.04 * 6.5)  # seven levels
        assert_expert_agrees(graph)
    assert added >= len(samples) // 3


def test_idle_covers_are_dropped_only_when_blocks_are_moved(samples: list[Sample]) -> None:
    dropped = 0
    for sample in samples:
        graph = drop_idle_covers(as_graph(sample), GEOMETRY)
        if graph.x.shape[0] < sample.x.shape[0]:
            dropped += 1
            assert int(sample.x[sample.object_index, 0]) == BLOCK
            assert not bool((graph.x[:, 0] == COVER).any())
            assert not bool((graph.x[:, 0] == 3).any())
        assert_expert_agrees(graph)
    assert dropped > 0


@pytest.mark.parametrize("levels", [1, 2, 4])
def test_dropping_finished_pairs_keeps_the_label_and_shrinks_graphs(
    samples: list[Sample], levels: int
) -> None:
    smallest = min(s.x.shape[0] for s in samples)
    shrunk, sizes = 0, []
    for sample in samples:
        graph = drop_finished_pairs(as_graph(sample), levels, GEOMETRY)
        removed = sample.x.shape[0] - graph.x.shape[0]
        assert removed % 2 == 0  # a filled goal goes with the block in it
        shrunk += removed > 0
        assert_expert_agrees(graph)
        bare = drop_idle_covers(graph, GEOMETRY)
        assert_expert_agrees(bare)
        sizes.append(bare.x.shape[0])
    assert shrunk >= len(samples) // 4
    # A 2-stack has four nodes; the demonstrations (K = 3, 4) show none that small.
    assert smallest > 4 and min(sizes) <= 4


def test_a_finished_goal_stack_moves_down_as_its_bottom_is_dropped() -> None:
    # Two blocks done at the bottom of a goal stack, two free goals above, one block to move.
    x = torch.tensor(
        [
            [1.0, 0.5, 0.2, 0.02, 0.0],  # the block to move
            [1.0, 0.4, -0.2, 0.02, 1.0],
            [1.0, 0.4, -0.2, 0.06, 1.0],
            [2.0, 0.4, -0.2, 0.02, 1.0],
            [2.0, 0.4, -0.2, 0.06, 1.0],
            [2.0, 0.4, -0.2, 0.10, 0.0],  # the expert's goal
            [2.0, 0.4, -0.2, 0.14, 0.0],
        ]
    )
    graph = drop_finished_pairs(Graph(x, 0, 5), 1, GEOMETRY)
    assert graph.x.shape[0] == 5
    assert graph.x[graph.goal_index].tolist() == pytest.approx([2.0, 0.4, -0.2, 0.06, 0.0])
    assert sorted(graph.x[graph.x[:, 0] == 2.0, 3].tolist()) == pytest.approx([0.02, 0.06, 0.1])
    assert_expert_agrees(graph)
    assert drop_finished_pairs(Graph(x, 1, 5), 2, GEOMETRY).x.shape[0] == 7  # not its object


def test_randomized_copies_keep_the_label_and_are_seeded(samples: list[Sample]) -> None:
    # Hiding a box's contents shows a partial view, which the expert cannot read (tested
    # above); position noise is perception noise: the label is the choice on the true scene,
    # which the expert's own footprint tests may read differently on a noisy copy.
    augmentation = Augmentation(
        copies=3, noise=0.0, noise_xy=0.0, translate_xy=0.0, translate_z=0.0, hide_probability=0.0
    )
    first = augmentation.apply(samples, torch.Generator().manual_seed(4))
    again = augmentation.apply(samples, torch.Generator().manual_seed(4))
    for a, b in zip(first, again, strict=True):
        assert torch.equal(a.x, b.x)
    for copy in first[len(samples) :]:
        assert torch.equal(copy.is_object, copy.x[:, 0] <= BLOCK)
        assert_expert_agrees(Graph(copy.x, copy.object_index, copy.goal_index))
    assert max(c.x.shape[0] for c in first) > max(s.x.shape[0] for s in samples) + 10


def test_unknown_probability_is_refused_by_name() -> None:
    with pytest.raises(ValueError, match="distractor_probability"):
        Augmentation(distractor_probability=1.5)
    with pytest.raises(ValueError, match="max_levels"):
        Augmentation(max_levels=-1)


def test_nothing_to_extend_returns_the_graph_itself() -> None:
    lone = Graph(torch.tensor([[1.0, 0.5, 0.0, 0.02, 0.0], [2.0, 0.5, 0.2, 0.02, 0.0]]), 0, 1)
    assert add_distractors(lone, True, True, torch.Generator(), GEOMETRY) is lone
    assert drop_idle_covers(lone, GEOMETRY) is lone
