from __future__ import annotations

import torch

from manigraph_planner.policies.gnn import best_compatible_pair

BLOCK, COVER, BLOCK_GOAL, COVER_GOAL = 1.0, 0.0, 2.0, 3.0


def test_independent_argmaxes_are_kept_when_compatible() -> None:
    pair = best_compatible_pair(
        torch.log(torch.tensor([0.1, 0.9])),
        torch.log(torch.tensor([0.7, 0.3])),
        torch.tensor([BLOCK, BLOCK]),
        torch.tensor([BLOCK_GOAL, BLOCK_GOAL]),
    )
    assert pair == (1, 0)


def test_a_block_is_never_sent_to_a_cover_goal() -> None:
    # The block is the likelier object and the storage place the likelier goal, but only a
    # cover can go there: the best compatible pair is the cover to the storage place.
    pair = best_compatible_pair(
        torch.log(torch.tensor([0.8, 0.2])),
        torch.log(torch.tensor([0.9, 0.1])),
        torch.tensor([BLOCK, COVER]),
        torch.tensor([COVER_GOAL, BLOCK_GOAL]),
    )
    assert pair == (1, 0)


def test_no_compatible_pair_means_no_decision() -> None:
    pair = best_compatible_pair(
        torch.zeros(1), torch.zeros(1), torch.tensor([BLOCK]), torch.tensor([COVER_GOAL])
    )
    assert pair is None


def test_ties_go_to_the_first_pair() -> None:
    pair = best_compatible_pair(
        torch.zeros(2), torch.zeros(2), torch.tensor([BLOCK, BLOCK]), torch.tensor([2.0, 2.0])
    )
    assert pair == (0, 0)
