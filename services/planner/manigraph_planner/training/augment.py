"""Augmentation: ~20 expert trajectories become ~900 training graphs (the paper's number).

Each demonstrated decision is kept and ``copies`` randomized copies of it are added. A copy
goes through these steps, none of which changes what the expert would decide:

1. **Tower extension** (probability ``tower_probability``): taller source towers, goal stacks
   with filled goals below and free goals above, up to ``max_levels`` each
   (:func:`~manigraph_planner.training.structure.extend_towers`). The demonstrations never
   show more than four blocks; the tests go to forty.
2. **Idle covers dropped** (probability ``drop_covers_probability``) where the expert moves a
   block and no cover lies over a box
   (:func:`~manigraph_planner.training.structure.drop_idle_covers`): the demonstrations always
   show a box; the stacking tasks never do. Then **distractors** (probability
   ``distractor_probability``; none where the covers were dropped): a closed box and/or a
   free storage place elsewhere on the table
   (:func:`~manigraph_planner.training.structure.add_distractors`). The demonstrations show
   one box; box rearrangement has two.
3. **Rigid translation** of the whole scene, uniform within ±``translate_xy`` in x and y and
   ``[0, translate_z]`` up: which block is highest or which goal lowest does not change when
   everything moves together.
4. **Position noise** on every node, Gaussian: ``noise_xy`` metres in x and y, ``noise`` in z.
   Both stay well below a block's size, so no stacked block changes place in the order and
   footprints still overlap; x/y noise teaches that goals need not stand in exact columns
   (a pyramid's do not).

Architectures that *sum* over their neighbours (``gcn``, ``gated``) get steps 3 and 4 only
(:func:`augmentation_for`): tower extension grows graphs from about 10 to about 90 nodes, a
sum grows with them, and measured on this project the sum architectures then lose even K = 9
stacking (gcn: 1.00 with steps 3-4 only, 0.00 with all four). ``sage`` (mean) and ``gat``
(attention) are normalised over neighbours and gain from every step.

Node order is not augmented: every architecture is permutation-equivariant (tested).
Why each step keeps the label is argued in :mod:`~manigraph_planner.training.structure` and
checked against the expert in ``tests/planner/training/test_structure.py``.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace

import torch

from manigraph_planner.training.dataset import Sample
from manigraph_planner.training.structure import (
    BLOCK,
    Graph,
    SceneGeometry,
    add_distractors,
    drop_idle_covers,
    extend_towers,
)


@dataclass(frozen=True)
class Augmentation:
    copies: int = 8
    translate_xy: float = 0.15
    translate_z: float = 0.6
    noise: float = 0.004
    noise_xy: float = 0.01
    tower_probability: float = 0.5
    max_levels: int = 24
    max_free_levels: int = 24
    distractor_probability: float = 0.5
    drop_covers_probability: float = 0.5
    geometry: SceneGeometry = field(default_factory=SceneGeometry)

    def __post_init__(self) -> None:
        if self.copies < 0:
            raise ValueError("copies: must be >= 0")
        for name in ("translate_xy", "translate_z", "noise", "noise_xy"):
            if getattr(self, name) < 0:
                raise ValueError(f"{name}: must be >= 0 metres")
        for name in ("tower_probability", "distractor_probability", "drop_covers_probability"):
            if not 0 <= getattr(self, name) <= 1:
                raise ValueError(f"{name}: must be in [0, 1]")
        for name in ("max_levels", "max_free_levels"):
            if getattr(self, name) < 0:
                raise ValueError(f"{name}: must be >= 0")

    def apply(self, samples: list[Sample], generator: torch.Generator) -> list[Sample]:
        """The originals followed by ``copies`` randomized copies of each."""
        out = list(samples)
        for _ in range(self.copies):
            for sample in samples:
                out.append(self.randomize(sample, generator))
        return out

    def randomize(self, sample: Sample, generator: torch.Generator) -> Sample:
        graph = Graph(sample.x, sample.object_index, sample.goal_index)
        if self._chance(self.tower_probability, generator):
            source, below = (self._levels(generator, self.max_levels) for _ in range(2))
            above = self._levels(generator, self.max_free_levels)
            graph = extend_towers(graph, source, below, above, self.geometry)
        if self._chance(self.drop_covers_probability, generator):
            graph = drop_idle_covers(graph, self.geometry)
        if self._chance(self.distractor_probability, generator):
            box, storage = (self._chance(0.5, generator) for _ in range(2))
            graph = add_distractors(graph, box, storage or not box, generator, self.geometry)
        x = self._jitter(graph.x, generator)
        return Sample(x, x[:, 0] <= BLOCK, graph.object_index, graph.goal_index)

    @staticmethod
    def _levels(generator: torch.Generator, most: int) -> int:
        return int(torch.randint(0, most + 1, (1,), generator=generator))

    @staticmethod
    def _chance(probability: float, generator: torch.Generator) -> bool:
        return probability > 0 and float(torch.rand(1, generator=generator)) < probability

    def _jitter(self, x: torch.Tensor, generator: torch.Generator) -> torch.Tensor:
        x = x.clone()
        shift = torch.empty(3)
        shift[:2] = (torch.rand(2, generator=generator) * 2 - 1) * self.translate_xy
        shift[2] = torch.rand(1, generator=generator).item() * self.translate_z
        x[:, 1:4] += shift
        sigma = torch.tensor([self.noise_xy, self.noise_xy, self.noise])
        x[:, 1:4] += torch.randn(x.shape[0], 3, generator=generator) * sigma
        return x


#: Architectures whose layers sum over neighbours: see the module docstring.
SUM_AGGREGATING = frozenset({"gcn", "gated"})


def augmentation_for(architecture: str, copies: int = 8) -> Augmentation:
    """The default augmentation for ``architecture`` with ``copies`` copies per sample."""
    if architecture in SUM_AGGREGATING:
        return Augmentation(
            copies=copies,
            noise_xy=0.004,
            tower_probability=0.0,
            distractor_probability=0.0,
            drop_covers_probability=0.0,
        )
    return replace(Augmentation(), copies=copies)
