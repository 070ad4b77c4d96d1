"""The augmented training sets of one run, each drawn while the network trains on the one before.

A recipe that resamples (``resample_every``) draws a fresh augmented set every few epochs; the
structural steps of the block family's recipes are Python, about 1.3 s a
draw on this machine, 15 draws in a 150-epoch run. A thread would not help (the training loop
and the draws both need the GIL), so after the first draw, taken in line, the others run in
one :class:`torch.utils.data.DataLoader` worker process, one draw ahead of the trainer, which
waits only for a draw that is not finished yet.

The results are those of drawing in line: every draw uses only the recipe's generator, whose
state passes to the worker after the first draw; the draws run one after another in the same
order; the worker flushes denormals as the trainer does. A draw crosses as five packed tensors
(:class:`PackedDraw`), not one shared-memory tensor per sample.
"""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass
from typing import Protocol

import torch
from torch import Tensor
from torch.utils.data import DataLoader, IterableDataset

from manigraph_training.dataset import Sample
from manigraph_training.recipes import Augmenter

__all__ = ["AugmentedDraws", "Draws", "InlineDraws", "PackedDraw", "draw_epochs"]


def draw_epochs(epochs: int, resample_every: int) -> list[int]:
    """The epochs (from 1) that start with a fresh draw: 1, then every ``resample_every``."""
    if resample_every <= 0:
        return [1]
    return [1, *range(1 + resample_every, epochs + 1, resample_every)]


@dataclass(frozen=True)
class PackedDraw:
    """One draw's samples as flat tensors: the node rows of every sample one after another."""

    x: Tensor  # (sum N, F)
    is_object: Tensor  # (sum N,) bool
    sizes: Tensor  # (B,) nodes per sample
    object_index: Tensor  # (B,)
    goal_index: Tensor  # (B,)

    @classmethod
    def pack(cls, samples: list[Sample]) -> PackedDraw:
        return cls(
            torch.cat([s.x for s in samples]),
            torch.cat([s.is_object for s in samples]),
            torch.tensor([s.x.shape[0] for s in samples]),
            torch.tensor([s.object_index for s in samples]),
            torch.tensor([s.goal_index for s in samples]),
        )

    def unpack(self) -> list[Sample]:
        sizes = self.sizes.tolist()
        columns = (
            self.x.split(sizes),
            self.is_object.split(sizes),
            self.object_index.tolist(),
            self.goal_index.tolist(),
        )
        return [Sample(*row) for row in zip(*columns, strict=True)]


class _Draws(IterableDataset[PackedDraw]):
    """``count`` draws, continuing from a generator state (the draws taken in line before)."""

    def __init__(
        self, augmentation: Augmenter, demos: list[Sample], generator_state: Tensor, count: int
    ):
        self._augmentation, self._demos = augmentation, demos
        self._generator_state, self._count = generator_state, count

    def __iter__(self) -> Iterator[PackedDraw]:
        torch.set_flush_denormal(True)  # per thread: as in the trainer
        generator = torch.Generator()
        generator.set_state(self._generator_state)
        for _ in range(self._count):
            yield PackedDraw.pack(self._augmentation.apply(self._demos, generator))


class Draws(Protocol):
    def take(self) -> list[Sample]:
        """The next augmented training set."""
        ...


class InlineDraws:
    """Draws in the trainer's own thread, for a run that draws once (nothing to overlap)."""

    def __init__(self, augmentation: Augmenter, demos: list[Sample], seed: int):
        self._augmentation, self._demos = augmentation, demos
        self.generator = torch.Generator().manual_seed(seed)

    def take(self) -> list[Sample]:
        return self._augmentation.apply(self._demos, self.generator)


class AugmentedDraws:
    """``count`` draws of ``augmentation`` on ``demos`` with a generator seeded ``seed``, in
    order: the first in line, the others one ahead in a worker process. Use as a context
    manager (ends the worker).

    The worker is forked (DataLoader's default on Linux, named here so that a later Python's
    default does not change it): a spawned one would re-run a user's script that calls
    ``train`` outside an ``if __name__ == "__main__"`` guard. The child runs only the draws,
    on one thread (DataLoader sets it). Where ``fork`` is missing, use :class:`InlineDraws`.
    """

    def __init__(self, augmentation: Augmenter, demos: list[Sample], seed: int, count: int):
        inline = InlineDraws(augmentation, demos, seed)
        self._first: list[Sample] | None = inline.take()
        self._iterator: Iterator[PackedDraw] | None = None
        if count > 1:
            draws = _Draws(augmentation, demos, inline.generator.get_state(), count - 1)
            # One worker keeps the order; prefetch_factor 1: one draw ahead, not two; its own
            # generator: the workers' base seed must not draw from the global one.
            loader = DataLoader(
                draws,
                batch_size=None,
                num_workers=1,
                prefetch_factor=1,
                multiprocessing_context="fork",
                generator=torch.Generator(),
            )
            self._iterator = iter(loader)
        self._closed = False

    def take(self) -> list[Sample]:
        """The next draw (waiting for it if the worker is still drawing it)."""
        if self._closed:
            raise RuntimeError("these draws are closed")
        if self._first is not None:
            first, self._first = self._first, None
            return first
        if self._iterator is None:
            raise RuntimeError("every draw of this run was taken")
        return next(self._iterator).unpack()

    def close(self) -> None:
        self._closed = True
        iterator, self._iterator = self._iterator, None
        shutdown = getattr(iterator, "_shutdown_workers", None)  # ends the worker now
        if shutdown is not None:
            shutdown()

    def __enter__(self) -> AugmentedDraws:
        return self

    def __exit__(self, *exc_info: object) -> None:
        self.close()
