"""Adam on every parameter of a network at once: the arithmetic of ``torch.optim.Adam``, one
kernel per operation for the whole network instead of one per parameter tensor."""

from __future__ import annotations

from collections.abc import Iterable

import torch
from torch import nn

__all__ = ["FlatAdam"]


class FlatAdam(torch.optim.Optimizer):
    r"""``torch.optim.Adam(params, lr, betas, eps, weight_decay)`` (its single-tensor path:
    no AMSGrad, not maximising), for parameters that all get a gradient at every step.

    ``torch.optim.Adam`` runs about ten tensor operations per parameter tensor per step; on a
    CPU even ``foreach=True`` loops over the tensors in C++. A GNN policy has ~17 small
    parameter tensors, so a step was ~170 dispatches (~10 % of a GAT or Gated training
    epoch). Here the parameters become views into one flat tensor, their gradients are
    concatenated once per step, and each operation runs once over everything: every element
    is updated by the same formula with the same Python scalars, so the weights are those
    ``torch.optim.Adam`` gives (tested bit for bit).

    :meth:`unflatten` gives each parameter its own storage again (call it before saving).
    """

    def __init__(
        self,
        params: Iterable[nn.Parameter],
        lr: float = 1e-3,
        betas: tuple[float, float] = (0.9, 0.999),
        eps: float = 1e-8,
        weight_decay: float = 0.0,
    ) -> None:
        self._params = list(params)
        defaults = {"lr": lr, "betas": betas, "eps": eps, "weight_decay": weight_decay}
        super().__init__(self._params, defaults)
        with torch.no_grad():
            self._flat = torch.cat([p.detach().reshape(-1) for p in self._params])
            offset = 0
            for p in self._params:
                p.data = self._flat[offset : offset + p.numel()].view_as(p)
                offset += p.numel()
        self._exp_avg = torch.zeros_like(self._flat)
        self._exp_avg_sq = torch.zeros_like(self._flat)
        self._steps = 0

    @torch.no_grad()
    def step(self, closure: None = None) -> None:  # type: ignore[override]
        if closure is not None:
            raise ValueError("FlatAdam takes no closure")
        missing = [i for i, p in enumerate(self._params) if p.grad is None]
        if missing:
            raise RuntimeError(f"FlatAdam: parameters {missing} got no gradient this step")
        group = self.param_groups[0]
        lr, (beta1, beta2) = group["lr"], group["betas"]
        eps, weight_decay = group["eps"], group["weight_decay"]
        grad = torch.cat([p.grad.reshape(-1) for p in self._params])  # type: ignore[union-attr]
        self._steps += 1
        step = float(self._steps)  # torch keeps a float32 step tensor and reads its value
        if weight_decay != 0:
            grad = grad.add(self._flat, alpha=weight_decay)
        self._exp_avg.lerp_(grad, 1 - beta1)
        self._exp_avg_sq.mul_(beta2).addcmul_(grad, grad, value=1 - beta2)
        bias_correction1 = 1 - beta1**step
        bias_correction2 = 1 - beta2**step
        step_size = lr / bias_correction1
        bias_correction2_sqrt = bias_correction2**0.5
        denom = (self._exp_avg_sq.sqrt() / bias_correction2_sqrt).add_(eps)
        self._flat.addcdiv_(self._exp_avg, denom, value=-step_size)

    def unflatten(self) -> None:
        """Each parameter in storage of its own (its values unchanged); no step after this."""
        with torch.no_grad():
            for p in self._params:
                p.data = p.data.clone()
