from __future__ import annotations

import pytest
import torch
from torch_geometric.data import Batch

from manigraph_planner.gnn.features import graph_from_arrays
from manigraph_planner.gnn.selection import select, selection_loss, split_logits

# Two graphs: graph 0 = 2 objects + 3 goals (nodes 0-4), graph 1 = 3 objects + 1 goal (5-8).
LOGITS = torch.tensor([0.5, -1.0, 2.0, 0.0, 1.0, 3.0, 3.0, -2.0, 0.7])
IS_OBJECT = torch.tensor([True, True, False, False, False, True, True, True, False])
BATCH = torch.tensor([0, 0, 0, 0, 0, 1, 1, 1, 1])


def test_split_logits_is_a_log_softmax_per_graph_over_objects_and_over_goals() -> None:
    log_prob = split_logits(LOGITS, IS_OBJECT, BATCH)
    for nodes in ([0, 1], [2, 3, 4], [5, 6, 7], [8]):
        torch.testing.assert_close(log_prob[nodes], LOGITS[nodes].log_softmax(0))


def test_split_logits_of_a_single_graph_needs_no_batch_vector() -> None:
    log_prob = split_logits(LOGITS[:5], IS_OBJECT[:5])
    torch.testing.assert_close(log_prob[:2], LOGITS[:2].log_softmax(0))
    torch.testing.assert_close(log_prob[2:5], LOGITS[2:5].log_softmax(0))


def test_loss_is_the_papers_cross_entropy_averaged_over_graphs() -> None:
    loss = selection_loss(LOGITS, IS_OBJECT, BATCH, torch.tensor([1, 7]), torch.tensor([3, 8]))
    expected = (
        -(
            LOGITS[[0, 1]].log_softmax(0)[1]
            + LOGITS[[2, 3, 4]].log_softmax(0)[1]
            + LOGITS[[5, 6, 7]].log_softmax(0)[2]
            + LOGITS[[8]].log_softmax(0)[0]
        )
        / 2
    )
    torch.testing.assert_close(loss, expected)


def test_loss_targets_in_a_pyg_batch_are_offset_per_graph() -> None:
    small = graph_from_arrays([1, 1, 2, 2, 2], torch.zeros(5, 3), [0] * 5)
    large = graph_from_arrays([1, 1, 1, 2], torch.zeros(4, 3), [0] * 4)
    batch = Batch.from_data_list(
        [
            small.to_data(object_index=torch.tensor([1]), goal_index=torch.tensor([3])),
            large.to_data(object_index=torch.tensor([2]), goal_index=torch.tensor([3])),
        ]
    )
    assert batch.object_index.tolist() == [1, 7] and batch.goal_index.tolist() == [3, 8]
    targets = (batch.object_index, batch.goal_index)
    loss = selection_loss(LOGITS, batch.is_object, batch.batch, *targets)
    direct = selection_loss(LOGITS, IS_OBJECT, BATCH, torch.tensor([1, 7]), torch.tensor([3, 8]))
    torch.testing.assert_close(loss, direct)


def test_loss_rejects_targets_of_the_wrong_kind() -> None:
    with pytest.raises(ValueError, match=r"^object_target:"):
        selection_loss(LOGITS, IS_OBJECT, BATCH, torch.tensor([2, 7]), torch.tensor([3, 8]))
    with pytest.raises(ValueError, match=r"^goal_target:"):
        selection_loss(LOGITS, IS_OBJECT, BATCH, torch.tensor([1, 7]), torch.tensor([0, 8]))


def test_select_takes_each_graphs_argmax_and_breaks_ties_by_lower_index() -> None:
    objects, goals = select(LOGITS, IS_OBJECT, BATCH)
    assert objects.tolist() == [0, 5]  # nodes 5 and 6 tie at 3.0
    assert goals.tolist() == [2, 8]


def test_select_reports_minus_one_for_a_graph_without_goals() -> None:
    objects, goals = select(LOGITS[5:8], IS_OBJECT[5:8])
    assert objects.tolist() == [0] and goals.tolist() == [-1]
