r"""How the trainer runs a :class:`~manigraph_planner.gnn.models.PolicyNet` on a list of
samples: as a padded dense batch of complete graphs, or as a PyG batch with explicit edges.

Both compute the same loss and choices from the same parameters, up to float rounding.
``"padded"`` is what training runs: the graphs of a batch, in groups of similar size, are
padded to their group's largest and every layer is dense algebra
(:mod:`~manigraph_planner.gnn.models.complete_graph`). ``"pyg"`` gathers and scatters along
the :math:`\sum_b N_b (N_b - 1)` edges of PyG message passing, the path the explainer needs
for edge masks; the trainer keeps it selectable as a reference.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from collections.abc import Sequence

import torch
from torch import Tensor
from torch_geometric.data import Batch, Data

from manigraph_planner.gnn.features import fully_connected_edge_index
from manigraph_planner.gnn.models import PolicyNet
from manigraph_planner.gnn.selection import (
    padded_select,
    padded_selection_loss,
    select,
    selection_loss,
)
from manigraph_planner.training.dataset import Sample
from manigraph_planner.training.padded_batch import PackedSamples, PaddedBatch, size_groups
from manigraph_shared.registry import Registry

__all__ = ["BATCH_LAYOUTS", "BatchLayout", "PaddedLayout", "PygLayout", "pyg_batch"]


class BatchLayout(ABC):
    """One way to batch samples through a network, for the loss and for the choices."""

    name: str

    @abstractmethod
    def loss(self, net: PolicyNet, samples: list[Sample]) -> Tensor:
        """The paper's Eq. (ce), averaged over ``samples`` (a scalar with gradients)."""

    def packed_loss(self, net: PolicyNet, packed: PackedSamples, indices: Sequence[int]) -> Tensor:
        """:meth:`loss` of the samples at ``indices`` of ``packed`` (what the trainer calls:
        it packs every draw once)."""
        return self.loss(net, [packed.samples[i] for i in indices])

    @abstractmethod
    def choices(self, net: PolicyNet, samples: list[Sample]) -> tuple[Tensor, Tensor]:
        """The network's argmax object and goal for each sample, as node indices within the
        sample's graph; -1 where it has no object (goal) nodes. Shapes: two :math:`(B,)`."""


class PaddedLayout(BatchLayout):
    """Samples through :meth:`PolicyNet.forward_complete` as one :class:`PaddedBatch` per
    group of similar sizes (:func:`size_groups`)."""

    name = "padded"

    def loss(self, net: PolicyNet, samples: list[Sample]) -> Tensor:
        return self.packed_loss(net, PackedSamples.pack(samples), range(len(samples)))

    def packed_loss(self, net: PolicyNet, packed: PackedSamples, indices: Sequence[int]) -> Tensor:
        parts = []
        for group in size_groups([packed.sizes[i] for i in indices]):
            batch = packed.padded([indices[i] for i in group]).to(_device_of(net))
            logits = net.forward_complete(batch.x, batch.mask)
            loss = padded_selection_loss(
                logits, batch.is_object, batch.mask, batch.object_index, batch.goal_index
            )
            parts.append(loss * (len(group) / len(indices)))  # a mean over all samples
        return torch.stack(parts).sum()

    def choices(self, net: PolicyNet, samples: list[Sample]) -> tuple[Tensor, Tensor]:
        objects = torch.empty(len(samples), dtype=torch.long)
        goals = torch.empty(len(samples), dtype=torch.long)
        for indices in size_groups([s.x.shape[0] for s in samples]):
            batch, logits = self._logits(net, [samples[i] for i in indices])
            chosen = padded_select(logits, batch.is_object, batch.mask)
            objects[indices], goals[indices] = (c.cpu() for c in chosen)
        return objects, goals

    @staticmethod
    def _logits(net: PolicyNet, samples: list[Sample]) -> tuple[PaddedBatch, Tensor]:
        batch = PaddedBatch.from_samples(samples).to(_device_of(net))
        return batch, net.forward_complete(batch.x, batch.mask)


class PygLayout(BatchLayout):
    """A :func:`pyg_batch` through :meth:`PolicyNet.forward` (PyG message passing)."""

    name = "pyg"

    def loss(self, net: PolicyNet, samples: list[Sample]) -> Tensor:
        batch, logits = self._logits(net, samples)
        return selection_loss(
            logits, batch.is_object, batch.batch, batch.object_index, batch.goal_index
        )

    def choices(self, net: PolicyNet, samples: list[Sample]) -> tuple[Tensor, Tensor]:
        batch, logits = self._logits(net, samples)
        chosen = select(logits, batch.is_object, batch.batch, batch.num_graphs)
        first_node = batch.ptr[:-1]  # select counts nodes across the whole batch
        objects, goals = (torch.where(c >= 0, c - first_node, -1).cpu() for c in chosen)
        return objects, goals

    @staticmethod
    def _logits(net: PolicyNet, samples: list[Sample]) -> tuple[Batch, Tensor]:
        batch = pyg_batch(samples).to(_device_of(net))
        return batch, net(batch.x, batch.edge_index, batch.batch)


def _device_of(net: PolicyNet) -> torch.device:
    return next(net.parameters()).device


def pyg_batch(samples: list[Sample]) -> Batch:
    """The samples as one PyG ``Batch`` of disjoint complete graphs; ``object_index`` and
    ``goal_index`` are offset by PyG into the batched node dimension."""
    return Batch.from_data_list(
        [
            Data(
                x=s.x,
                edge_index=fully_connected_edge_index(s.x.shape[0]),
                is_object=s.is_object,
                object_index=torch.tensor([s.object_index]),
                goal_index=torch.tensor([s.goal_index]),
            )
            for s in samples
        ]
    )


#: Batch layouts by name; :class:`~manigraph_planner.training.trainer.TrainConfig` names one.
BATCH_LAYOUTS: Registry[BatchLayout] = Registry("batch_layout")
for _layout in (PaddedLayout(), PygLayout()):
    BATCH_LAYOUTS.add(_layout.name, _layout)
