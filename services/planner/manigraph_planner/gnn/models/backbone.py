"""The swappable part of a GNN policy: message-passing layers, registered by name."""

from __future__ import annotations

from abc import ABC, abstractmethod

from torch import Tensor, nn

from manigraph_planner.gnn.models.complete_graph import message_passing_on_complete
from manigraph_shared.registry import Registry

__all__ = ["ARCHITECTURES", "Backbone", "ConvStack", "register_architecture"]


class Backbone(nn.Module, ABC):
    """Maps node features to hidden node states by message passing over ``edge_index``.

    Args:
        in_channels: size of each input node feature.
        hidden_channels: size of each hidden node state (the paper: 64).
        num_layers: number of message-passing layers (the paper: 3).
        message_passing: build PyG's layers (training, the explainer); False: only their
            weights (:mod:`~manigraph_planner.gnn.models.layer_weights`), enough for
            :meth:`forward_complete` and without importing PyG (policy serving).

    Shapes:
        - **input:** node features :math:`(N, F_{in})`, edge indices :math:`(2, E)`
        - **output:** hidden node states :math:`(N, F_{hidden})`

    :meth:`forward` is PyG message passing: batches of disjoint graphs, any edges, edge masks
    (the explainer). :meth:`forward_complete` is the same function of the same parameters for
    one complete graph (policy inference) or a padded batch of them (training).
    """

    name: str

    def __init__(
        self, in_channels: int, hidden_channels: int, num_layers: int, message_passing: bool = True
    ) -> None:
        super().__init__()
        self.in_channels = in_channels
        self.hidden_channels = hidden_channels
        self.num_layers = num_layers
        self.message_passing = message_passing

    @abstractmethod
    def forward(self, x: Tensor, edge_index: Tensor) -> Tensor:
        """Hidden node states."""

    def forward_complete(self, x: Tensor, mask: Tensor | None = None) -> Tensor:
        """Hidden node states of one complete graph without self loops, i.e. ``forward(x,
        fully_connected_edge_index(N))`` up to float rounding; or of each graph of a padded
        batch of them, as if run one by one.

        This default runs :meth:`forward` on the explicit edge index; architectures override
        it with dense algebra (:mod:`~manigraph_planner.gnn.models.complete_graph`), which
        needs no per-edge tensors.

        Shapes:
            - **x:** :math:`(N, F_{in})`, or :math:`(B, N_{max}, F_{in})` with **mask**
              :math:`(B, N_{max})`, True for real nodes
            - **output:** :math:`(N, F_{hidden})`, or :math:`(B, N_{max}, F_{hidden})`;
              finite but unspecified at padded nodes
        """
        return message_passing_on_complete(self, x, mask)


class ConvStack(Backbone):
    r"""``num_layers`` convolutions, each followed by ReLU:
    :math:`h^l = \mathrm{ReLU}(\mathrm{conv}_l(h^{l-1}, E))`, :math:`h^0 = \phi`.

    Subclasses say which convolution to stack, in :meth:`make_conv`, and how one acts on a
    complete graph, in :meth:`conv_complete`.
    """

    def __init__(
        self, in_channels: int, hidden_channels: int, num_layers: int, message_passing: bool = True
    ) -> None:
        super().__init__(in_channels, hidden_channels, num_layers, message_passing)
        sizes = [in_channels] + [hidden_channels] * num_layers
        make = self.make_conv if message_passing else self.make_weights
        self.convs = nn.ModuleList(
            make(sizes[layer], sizes[layer + 1]) for layer in range(num_layers)
        )

    @abstractmethod
    def make_conv(self, in_channels: int, out_channels: int) -> nn.Module:
        """One message-passing layer, called as ``conv(x, edge_index)``."""

    def make_weights(self, in_channels: int, out_channels: int) -> nn.Module:
        """The parameters of the layer :meth:`make_conv` makes, under the same names, for
        :meth:`conv_complete` only. This default is the layer itself: an architecture
        without a weights-only twin still serves, importing PyG."""
        return self.make_conv(in_channels, out_channels)

    def conv_complete(self, conv: nn.Module, x: Tensor, mask: Tensor | None = None) -> Tensor:
        """``conv(x, fully_connected_edge_index(N))`` for one layer made by :meth:`make_conv`,
        on one graph or a padded batch (shapes as in :meth:`forward_complete`); this default
        builds the edge index, subclasses override it with dense algebra."""
        return message_passing_on_complete(conv, x, mask)

    def forward(self, x: Tensor, edge_index: Tensor) -> Tensor:
        for conv in self.convs:
            x = conv(x, edge_index).relu()
        return x

    def forward_complete(self, x: Tensor, mask: Tensor | None = None) -> Tensor:
        for conv in self.convs:
            x = self.conv_complete(conv, x, mask).relu()
        return x


#: Backbone classes by architecture name; checkpoints name one of these. An architecture
#: takes no options of its own: its sizes are :class:`~.config.ModelConfig`'s, the same for all.
ARCHITECTURES: Registry[type[Backbone]] = Registry("architecture")
#: Class decorator adding a :class:`Backbone` to :data:`ARCHITECTURES` under a name.
register_architecture = ARCHITECTURES.register
