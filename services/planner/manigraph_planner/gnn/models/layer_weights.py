"""The parameters of PyG's four convolutions, held by plain torch modules.

Policy inference runs the dense complete-graph path
(:meth:`~manigraph_planner.gnn.models.Backbone.forward_complete`), which reads a layer's
weights and never calls its message passing. A planner serving a checkpoint therefore builds
its backbone from these holders (``message_passing=False``) and never imports PyG: that import
(with the ``torch._dynamo`` it pulls in) costs ~2 s of start-up on two cores.

Each holder has exactly the parameter names and shapes of the PyG layer it stands for, so a
checkpoint's ``state_dict`` loads into either with ``strict=True`` (a mismatch is refused by
name), and the explainer, which needs message passing for its edge masks, rebuilds the PyG
network from the same state (:func:`~manigraph_planner.gnn.models.build.with_message_passing`).
Calling a holder as a layer raises: it has no edges to pass messages over.
"""

from __future__ import annotations

import torch
from torch import Tensor, nn

from manigraph_shared.errors import PolicyError


class LayerWeights(nn.Module):
    """Base: a PyG layer's parameters without its message passing."""

    stands_for: str

    def forward(self, *_args: object) -> Tensor:
        raise PolicyError(
            f"{type(self).__name__}: the weights of a {self.stands_for} serve the dense path "
            "only; message passing (edge masks, any edge index) needs the PyG network "
            "(build it with message_passing=True)"
        )


class SAGEWeights(LayerWeights):
    """``SAGEConv(aggr="mean", root_weight=True)``: ``lin_l`` (neighbours, with bias) and
    ``lin_r`` (the node itself)."""

    stands_for = "SAGEConv"

    def __init__(self, in_channels: int, out_channels: int) -> None:
        super().__init__()
        self.lin_l = nn.Linear(in_channels, out_channels, bias=True)
        self.lin_r = nn.Linear(in_channels, out_channels, bias=False)


class GraphConvWeights(LayerWeights):
    """``GraphConv(aggr="add")``: ``lin_rel`` (neighbours, with bias) and ``lin_root``."""

    stands_for = "GraphConv"

    def __init__(self, in_channels: int, out_channels: int) -> None:
        super().__init__()
        self.lin_rel = nn.Linear(in_channels, out_channels, bias=True)
        self.lin_root = nn.Linear(in_channels, out_channels, bias=False)


class GATWeights(LayerWeights):
    """``GATConv(heads=1, add_self_loops=False, residual=True)``: the shared projection
    ``lin``, the attention vectors ``att_src``/``att_dst`` (shape ``(1, 1, C)``), the residual
    ``res`` and the output ``bias``; PyG's default ``negative_slope`` 0.2."""

    stands_for = "GATConv"

    def __init__(self, in_channels: int, out_channels: int, negative_slope: float = 0.2) -> None:
        super().__init__()
        self.negative_slope = negative_slope
        self.lin = nn.Linear(in_channels, out_channels, bias=False)
        self.att_src = nn.Parameter(torch.empty(1, 1, out_channels))
        self.att_dst = nn.Parameter(torch.empty(1, 1, out_channels))
        self.res = nn.Linear(in_channels, out_channels, bias=False)
        self.bias = nn.Parameter(torch.zeros(out_channels))
        nn.init.xavier_uniform_(self.att_src)
        nn.init.xavier_uniform_(self.att_dst)


class GatedWeights(LayerWeights):
    """``GatedGraphConv(out_channels, num_layers, aggr="add")``: one ``weight`` matrix per
    propagation step, shape ``(num_layers, C, C)``, and the ``rnn`` GRU cell."""

    stands_for = "GatedGraphConv"

    def __init__(self, out_channels: int, num_layers: int) -> None:
        super().__init__()
        self.weight = nn.Parameter(torch.empty(num_layers, out_channels, out_channels))
        self.rnn = nn.GRUCell(out_channels, out_channels)
        nn.init.xavier_uniform_(self.weight)
