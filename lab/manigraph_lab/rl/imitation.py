r"""RL-GNN-demo's auxiliary imitation loss: PPO's loss plus :math:`\lambda_{IL}` times the
paper's cross-entropy on the expert demonstrations,

.. math::
    \mathcal{L} = \mathcal{L}_{PPO} + \lambda_{IL}\, \mathbb{E}_{(s^E, a^E) \sim
    \mathcal{D}^{Expert}} \big[ \mathcal{H}(\pi_\theta(\cdot \mid s^E), a^E) \big],

with :math:`\mathcal{H}` the IL trainer's own loss
(:func:`~manigraph_planner.gnn.selection.padded_selection_loss`: object and goal
cross-entropy) on a fresh minibatch of demonstration graphs at every gradient step.

stable-baselines3's PPO has no hook for an extra loss term, so the term enters through the
optimizer: :class:`ImitationAdam` adds :math:`\lambda_{IL} \nabla \mathcal{H}` to the
gradients PPO has just computed, then takes Adam's step. The gradient is that of
:math:`\mathcal{L}`, except that PPO's gradient-norm clipping applies to the PPO part only.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence

import torch
from torch import Tensor

from manigraph_planner.gnn.models import PolicyNet
from manigraph_planner.gnn.selection import padded_selection_loss
from manigraph_shared.errors import ConfigError
from manigraph_training.dataset import Sample
from manigraph_training.padded_batch import PaddedBatch

__all__ = ["ImitationAdam", "ImitationTerm"]


class ImitationTerm:
    r""":math:`\lambda_{IL} \mathcal{H}` on minibatches of expert samples.

    Args:
        net: the policy's GNN (its parameters receive the gradient).
        samples: expert decisions (:func:`~manigraph_training.dataset.load_demonstrations`).
        weight: :math:`\lambda_{IL}`, >= 0.
        batch_size: samples per gradient step.
        seed: seed of the minibatch draws.
    """

    def __init__(
        self,
        net: PolicyNet,
        samples: Sequence[Sample],
        weight: float,
        batch_size: int = 32,
        seed: int = 0,
    ) -> None:
        if not samples:
            raise ConfigError("demonstrations", "need at least one expert sample")
        if weight < 0:
            raise ConfigError("imitation_weight", f"must be >= 0, got {weight}")
        if batch_size < 1:
            raise ConfigError("imitation_batch", f"must be >= 1, got {batch_size}")
        self.net = net
        self.samples = list(samples)
        self.weight = weight
        self.batch_size = min(batch_size, len(self.samples))
        self.generator = torch.Generator().manual_seed(seed)
        self.losses: list[float] = []

    def loss(self) -> Tensor:
        """:math:`\\mathcal{H}` on one minibatch (without the weight)."""
        picks = torch.randperm(len(self.samples), generator=self.generator)[: self.batch_size]
        batch = PaddedBatch.from_samples([self.samples[int(i)] for i in picks])
        logits = self.net.forward_complete(batch.x, batch.mask)
        return padded_selection_loss(
            logits, batch.is_object, batch.mask, batch.object_index, batch.goal_index
        )

    def add_gradients(self) -> None:
        """Accumulate :math:`\\lambda_{IL} \\nabla \\mathcal{H}` into the parameters' grads."""
        with torch.enable_grad():
            loss = self.loss()
            (self.weight * loss).backward()
        self.losses.append(float(loss.detach()))


class ImitationAdam(torch.optim.Adam):
    """Adam that first adds an :class:`ImitationTerm`'s gradients, when one is attached
    (``optimizer.imitation = term``); without one it is plain Adam. Used as the policy's
    ``optimizer_class``, so a saved model reloads with it and only the term is re-attached."""

    imitation: ImitationTerm | None = None

    def step(self, closure: Callable[[], float] | None = None) -> float | None:  # type: ignore[override]
        if self.imitation is not None:
            self.imitation.add_gradients()
        return super().step(closure)
