r"""A head that scores (object, goal) pairs for the ``pairs`` decoder: the goal given the
object, from the two nodes' own features.

.. math::
    s(o, g) = x_o^\top M x_g

:math:`x` are the (scaled) input features, and :math:`M` holds one learned weight per pair
of columns: ``colour=red`` of the object with ``goal.colour=red`` of the goal ("this block
matches that bin"), with the goal's ``y`` ("red goes left"), with its ``filled``; a goal
column with the object's constant ``category`` column is a per-goal score (a bin's rank by
where it stands). No sum of per-node scores can express the first two.

Why so small a head, measured on ten demonstrations of "same colour as the bin" (validation
seeds, docs/training.md): a head over the message-passing states (an MLP over
:math:`[h_o, h_g]` and :math:`(Q h_o)^\top (K h_g)`, with or without the node logits) fits
each demonstrated scene as a whole and sends every block to the bin the teacher filled next,
whatever its colour (0.27-0.73 at the demonstrated size); an MLP over :math:`[x_o, x_g]`
beside :math:`M` holds at the demonstrated size but ranks a new bin's position above the
colour match at 3x the objects (0.70 / 0.90, training seeds 0 / 1). Linear in each node,
this head can neither memorise a scene nor rank an unseen position above the match it
learned. The object itself is still chosen by the graph network (:math:`p(o)`, the paper's
object head).
"""

from __future__ import annotations

from torch import Tensor, nn

__all__ = ["PairHead"]


class PairHead(nn.Module):
    """Pair logits from node features.

    Shapes:
        - **x:** the scaled input features, :math:`(N, F)` or :math:`(B, N, F)`
        - **output:** :math:`(N, N)` or :math:`(B, N, N)`, ``[o, g]`` the score of node
          ``o`` as the object and node ``g`` as the goal (every node pair; the decoder masks
          those that are not an object and a compatible goal)
    """

    def __init__(self, in_channels: int) -> None:
        super().__init__()
        self.bilinear = nn.Linear(in_channels, in_channels, bias=False)

    def forward(self, x: Tensor) -> Tensor:
        # bilinear(x)[g] @ x[o] = x_g^T W x_o: transposed, [o, g] = x_o^T W^T x_g
        return (self.bilinear(x) @ x.transpose(-1, -2)).transpose(-1, -2)
