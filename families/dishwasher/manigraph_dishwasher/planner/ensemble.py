r"""Several dishwasher networks read as one: the mean of their logits.

.. math::
    \ell = \frac{1}{M} \sum_{m=1}^{M} \ell_m

for each of the four heads. Every softmax the decoder takes (dishes, slots, six
orientations, three tray actions) is shift-invariant, so the softmax of :math:`\ell` is the
softmax of the members' mean log-probabilities: the ensemble decides by the geometric mean
of its members' distributions, and one member's confident mistake at a count of dishes it
was never shown is outvoted when the others disagree. The members are stored in one
checkpoint (``model.ensemble`` = :math:`M`, parameters under ``members.<m>.``).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence

import torch
from torch import Tensor, nn

from manigraph_dishwasher.planner.net import DishHeads, DishPolicyNet
from manigraph_planner.gnn.models.config import ModelConfig

__all__ = ["DishEnsembleNet"]


class DishEnsembleNet(DishPolicyNet):
    """``config.ensemble`` :class:`DishPolicyNet` members of one architecture; every output
    is the mean of theirs. It is a :class:`DishPolicyNet` to whatever decodes one, but holds
    no weights of its own (its ``__init__`` skips the single network's layers)."""

    def __init__(
        self,
        config: ModelConfig,
        members: Sequence[DishPolicyNet] | None = None,
        message_passing: bool = True,
    ):
        nn.Module.__init__(self)
        self.config = config
        member_config = dataclasses.replace(config, ensemble=1)
        if members is None:
            members = [
                DishPolicyNet(member_config, message_passing) for _ in range(config.ensemble)
            ]
        self.message_passing = all(m.message_passing for m in members)
        if len(members) != config.ensemble or any(m.config != member_config for m in members):
            raise ValueError(f"ensemble: needs {config.ensemble} members built as {member_config}")
        self.members = nn.ModuleList(members)

    @classmethod
    def of(cls, members: Sequence[DishPolicyNet]) -> DishEnsembleNet:
        """The ensemble of ``members`` (trained networks with one config)."""
        config = dataclasses.replace(members[0].config, ensemble=len(members))
        return cls(config, members)

    def heads_complete(self, x: Tensor, mask: Tensor | None = None) -> DishHeads:
        outputs = [m.heads_complete(x, mask) for m in self._members()]
        return DishHeads(*(torch.stack(h).mean(dim=0) for h in zip(*outputs, strict=True)))

    def forward(self, x: Tensor, edge_index: Tensor, batch: Tensor | None = None) -> Tensor:
        return torch.stack([m(x, edge_index, batch) for m in self._members()]).mean(dim=0)

    def forward_complete(self, x: Tensor, mask: Tensor | None = None) -> Tensor:
        return torch.stack([m.forward_complete(x, mask) for m in self._members()]).mean(dim=0)

    def _members(self) -> list[DishPolicyNet]:
        return [m for m in self.members if isinstance(m, DishPolicyNet)]


def dish_network(config: ModelConfig, message_passing: bool = True) -> DishPolicyNet:
    """The dishwasher heads' network for ``config``: one :class:`DishPolicyNet`, or an
    ensemble of them (``config.ensemble`` > 1); the family's ``network`` part."""
    if config.ensemble > 1:
        return DishEnsembleNet(config, message_passing=message_passing)
    return DishPolicyNet(config, message_passing)
