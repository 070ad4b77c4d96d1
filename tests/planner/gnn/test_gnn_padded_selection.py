"""The padded-batch loss and choice equal the PyG (scatter) ones on the same graphs."""

from __future__ import annotations

import pytest
import torch
from torch.nn.utils.rnn import pad_sequence

from manigraph_planner.gnn.selection import (
    padded_select,
    padded_selection_loss,
    padded_split_logits,
    select,
    selection_loss,
    split_logits,
)

# Graphs of 5, 2, 9 and 4 nodes; each has objects first, then goals, except graph 3, whose
# nodes alternate (the padded functions must not assume an order).
SIZES = (5, 2, 9, 4)
IS_OBJECT = [
    torch.tensor([True, True, False, False, False]),
    torch.tensor([True, False]),
    torch.tensor([True] * 6 + [False] * 3),
    torch.tensor([False, True, False, True]),
]
OBJECT_TARGET = torch.tensor([1, 0, 4, 3])  # within each graph
GOAL_TARGET = torch.tensor([4, 1, 7, 0])


def random_logits(seed: int) -> list[torch.Tensor]:
    gen = torch.Generator().manual_seed(seed)
    return [torch.randn(n, generator=gen, dtype=torch.float64) for n in SIZES]


def as_padded(per_graph: list[torch.Tensor], padding: float = 0.0) -> torch.Tensor:
    return pad_sequence(per_graph, batch_first=True, padding_value=padding)


MASK = as_padded([torch.ones(n, dtype=torch.bool) for n in SIZES])
PADDED_IS_OBJECT = as_padded(IS_OBJECT)
BATCH = torch.cat([torch.full((n,), b) for b, n in enumerate(SIZES)])
FIRST_NODE = torch.tensor([0, *SIZES]).cumsum(0)[:-1]


def pyg_loss(logits: list[torch.Tensor]) -> torch.Tensor:
    return selection_loss(
        torch.cat(logits),
        torch.cat(IS_OBJECT),
        BATCH,
        FIRST_NODE + OBJECT_TARGET,
        FIRST_NODE + GOAL_TARGET,
    )


def padded_loss(logits: torch.Tensor) -> torch.Tensor:
    return padded_selection_loss(logits, PADDED_IS_OBJECT, MASK, OBJECT_TARGET, GOAL_TARGET)


def test_padded_loss_and_its_gradient_equal_the_pyg_ones_in_float64() -> None:
    per_graph = [logits.requires_grad_() for logits in random_logits(seed=0)]
    expected = pyg_loss(per_graph)
    expected.backward()
    padded_logits = as_padded([logits.detach() for logits in per_graph], padding=50.0)
    padded_logits.requires_grad_()
    loss = padded_loss(padded_logits)
    loss.backward()
    torch.testing.assert_close(loss, expected, atol=1e-12, rtol=0)
    assert padded_logits.grad is not None
    for b, logits in enumerate(per_graph):
        assert logits.grad is not None
        torch.testing.assert_close(
            padded_logits.grad[b, : SIZES[b]], logits.grad, atol=1e-12, rtol=0
        )
    assert bool((padded_logits.grad[~MASK] == 0).all())  # padding takes no part


def test_padded_split_logits_equals_the_pyg_one_and_is_minus_inf_at_padding() -> None:
    per_graph = random_logits(seed=1)
    expected = split_logits(torch.cat(per_graph), torch.cat(IS_OBJECT), BATCH)
    log_prob = padded_split_logits(as_padded(per_graph), PADDED_IS_OBJECT, MASK)
    torch.testing.assert_close(log_prob[MASK], expected, atol=1e-12, rtol=0)
    assert bool((log_prob[~MASK] == float("-inf")).all())


def test_padded_select_equals_the_pyg_one_with_ties_to_the_lower_index() -> None:
    per_graph = random_logits(seed=2)
    per_graph[2][[1, 3]] = 9.0  # a tie between objects 1 and 3 of graph 2
    objects, goals = select(torch.cat(per_graph), torch.cat(IS_OBJECT), BATCH)
    padded_objects, padded_goals = padded_select(
        as_padded(per_graph, padding=99.0), PADDED_IS_OBJECT, MASK
    )
    assert padded_objects.tolist() == (objects - FIRST_NODE).tolist()
    assert padded_goals.tolist() == (goals - FIRST_NODE).tolist()
    assert padded_objects[2] == 1


def test_padded_select_reports_minus_one_for_a_graph_without_goals() -> None:
    real = torch.tensor([[True, True, False]])
    objects, goals = padded_select(torch.zeros(1, 3), is_object=real, mask=real)
    assert objects.tolist() == [0] and goals.tolist() == [-1]


def test_padded_loss_rejects_targets_of_the_wrong_kind_or_in_the_padding() -> None:
    logits = as_padded(random_logits(seed=3))
    with pytest.raises(ValueError, match=r"^object_target:"):
        padded_selection_loss(
            logits, PADDED_IS_OBJECT, MASK, torch.tensor([2, 0, 4, 3]), GOAL_TARGET
        )
    with pytest.raises(ValueError, match=r"^goal_target:"):  # slot 5 of graph 1 is padding
        padded_selection_loss(
            logits, PADDED_IS_OBJECT, MASK, OBJECT_TARGET, torch.tensor([4, 5, 7, 0])
        )
