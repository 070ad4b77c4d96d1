"""Augmentation: ~20 expert trajectories become ~900 training graphs (the paper's number).

What we chose, and why each keeps the expert's label correct:

* **Rigid translation** of the whole scene in x, y and z (uniform, ``translate`` metres):
  which block is highest or which goal is lowest does not change when everything moves
  together. The z shift also shows the network absolute heights far above the training
  stacks, which is what generalising from K = 4 to K = 40 needs.
* **Position noise** on every node (Gaussian, ``noise`` metres, well below a block's size):
  robustness to perception noise without reordering stacked blocks.
* **Node order** is not augmented: every architecture is permutation-equivariant (tested).
"""

from __future__ import annotations

from dataclasses import dataclass

import torch

from manigraph_planner.training.dataset import Sample


@dataclass(frozen=True)
class Augmentation:
    copies: int = 8
    translate_xy: float = 0.15
    translate_z: float = 0.6
    noise: float = 0.004

    def __post_init__(self) -> None:
        if self.copies < 0:
            raise ValueError("copies: must be >= 0")
        for name in ("translate_xy", "translate_z", "noise"):
            if getattr(self, name) < 0:
                raise ValueError(f"{name}: must be >= 0 metres")

    def apply(self, samples: list[Sample], generator: torch.Generator) -> list[Sample]:
        """The originals followed by ``copies`` randomized copies of each."""
        out = list(samples)
        for _ in range(self.copies):
            for sample in samples:
                out.append(sample.with_x(self._jitter(sample.x, generator)))
        return out

    def _jitter(self, x: torch.Tensor, generator: torch.Generator) -> torch.Tensor:
        x = x.clone()
        shift = torch.empty(3)
        shift[:2] = (torch.rand(2, generator=generator) * 2 - 1) * self.translate_xy
        shift[2] = torch.rand(1, generator=generator).item() * self.translate_z
        x[:, 1:4] += shift
        x[:, 1:4] += torch.randn(x.shape[0], 3, generator=generator) * self.noise
        return x
