r"""How the trainer runs a :class:`~manigraph_planner.gnn.models.PolicyNet` on a list of
samples: as a padded dense batch of complete graphs, or as a PyG batch with explicit edges.

Both compute the same loss and choices from the same parameters, up to float rounding.
``"padded"`` is what training runs: the graphs of a batch, in groups of similar size, are
padded to their group's largest and every layer is dense algebra
(:mod:`~manigraph_planner.gnn.models.complete_graph`). ``"pyg"`` gathers and scatters along
the :math:`\sum_b N_b (N_b - 1)` edges of PyG message passing, the path the explainer needs
for edge masks; the trainer keeps it selectable as a reference.

A network with a ``pairs`` decoder (``net.decodes_pairs``) is trained and read by its pair
logits instead (:mod:`~manigraph_planner.gnn.pair_decoder`), in both layouts.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from collections.abc import Sequence

import torch
from torch import Tensor
from torch_geometric.data import Batch, Data

from manigraph_planner.gnn.features import fully_connected_edge_index
from manigraph_planner.gnn.models import PolicyNet
from manigraph_planner.gnn.pair_decoder import (
    padded_pair_loss,
    padded_pair_select,
    padded_valid_pairs,
)
from manigraph_planner.gnn.selection import (
    padded_select,
    padded_selection_loss,
    select,
    selection_loss,
)
from manigraph_shared.registry import Registry
from manigraph_training.dataset import Sample
from manigraph_training.padded_batch import PackedSamples, PaddedBatch, size_groups

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
            if net.decodes_pairs:
                loss = padded_pair_loss(
                    *net.pairs_complete(batch.x, batch.mask),
                    batch.is_object,
                    batch.mask,
                    padded_valid_pairs(batch.x, batch.is_object, batch.mask),
                    batch.object_index,
                    batch.goal_index,
                )
            else:
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
            if net.decodes_pairs:
                batch = PaddedBatch.from_samples([samples[i] for i in indices])
                batch = batch.to(_device_of(net))
                valid = padded_valid_pairs(batch.x, batch.is_object, batch.mask)
                node_logits, pair_logits = net.pairs_complete(batch.x, batch.mask)
                chosen = padded_pair_select(
                    node_logits, pair_logits, batch.is_object, batch.mask, valid
                )
                objects[indices], goals[indices] = (c.cpu() for c in chosen)
                continue
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
        if net.decodes_pairs:
            return torch.stack([_one_graph_pair_loss(net, s) for s in samples]).mean()
        batch, logits = self._logits(net, samples)
        return selection_loss(
            logits, batch.is_object, batch.batch, batch.object_index, batch.goal_index
        )

    def choices(self, net: PolicyNet, samples: list[Sample]) -> tuple[Tensor, Tensor]:
        if net.decodes_pairs:
            picked = [_one_graph_pair_choice(net, s) for s in samples]
            return torch.tensor([o for o, _ in picked]), torch.tensor([g for _, g in picked])
        batch, logits = self._logits(net, samples)
        chosen = select(logits, batch.is_object, batch.batch, batch.num_graphs)
        first_node = batch.ptr[:-1]  # select counts nodes across the whole batch
        objects, goals = (torch.where(c >= 0, c - first_node, -1).cpu() for c in chosen)
        return objects, goals

    @staticmethod
    def _logits(net: PolicyNet, samples: list[Sample]) -> tuple[Batch, Tensor]:
        batch = pyg_batch(samples).to(_device_of(net))
        return batch, net(batch.x, batch.edge_index, batch.batch)


def _one_graph_pairs(
    net: PolicyNet, sample: Sample
) -> tuple[Tensor, Tensor, Tensor, Tensor, Tensor]:
    """Node and pair logits of one sample by PyG message passing, as a padded batch of one
    graph with its node mask and valid pairs (for the :class:`PygLayout` reference)."""
    device = _device_of(net)
    x = sample.x.to(device)
    node_logits = net(x, fully_connected_edge_index(x.shape[0]).to(device)).unsqueeze(0)
    pair_logits = net.pair_logits(x).unsqueeze(0)
    is_object = sample.is_object.to(device).unsqueeze(0)
    mask = torch.ones_like(is_object)
    valid = padded_valid_pairs(x.unsqueeze(0), is_object, mask)
    return node_logits, pair_logits, is_object, mask, valid


def _one_graph_pair_loss(net: PolicyNet, sample: Sample) -> Tensor:
    parts = _one_graph_pairs(net, sample)
    device = parts[0].device
    target = torch.tensor([sample.object_index], device=device)
    goal = torch.tensor([sample.goal_index], device=device)
    return padded_pair_loss(*parts, target, goal)


def _one_graph_pair_choice(net: PolicyNet, sample: Sample) -> tuple[int, int]:
    objects, goals = padded_pair_select(*_one_graph_pairs(net, sample))
    return int(objects[0]), int(goals[0])


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


#: Batch layouts by name; :class:`~manigraph_training.trainer.TrainConfig` names one.
BATCH_LAYOUTS: Registry[BatchLayout] = Registry("batch_layout")
for _layout in (PaddedLayout(), PygLayout()):
    BATCH_LAYOUTS.add(_layout.name, _layout)
