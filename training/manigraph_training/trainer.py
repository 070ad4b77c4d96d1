"""The imitation-learning loop: minimise the paper's cross-entropy (eq. ce) over demonstrations."""

from __future__ import annotations

import multiprocessing
import random
import re
import time
from collections.abc import Callable
from dataclasses import asdict, dataclass, replace
from typing import TextIO

import torch

from manigraph_planner.gnn.features import FeatureSpec
from manigraph_planner.gnn.models import ModelConfig, PolicyNet
from manigraph_shared.errors import ConfigError
from manigraph_shared.progress import Progress
from manigraph_training.augmented_draws import (
    AugmentedDraws,
    Draws,
    InlineDraws,
    draw_epochs,
)
from manigraph_training.batch_layouts import BATCH_LAYOUTS
from manigraph_training.dataset import Demonstrations, Sample
from manigraph_training.flat_adam import FlatAdam
from manigraph_training.padded_batch import PackedSamples, PaddedBatch
from manigraph_training.recipes import Augmenter, augmentation_for, resample_every_for

#: Called after every epoch with the epoch (from 1) and its mean training loss.
EpochCallback = Callable[[int, float], None]


@dataclass(frozen=True)
class TrainConfig:
    architecture: str = "sage"
    seed: int = 0
    epochs: int = 150
    batch_size: int = 64
    learning_rate: float = 3e-3
    weight_decay: float = 0.0
    hidden_channels: int = 64
    num_layers: int = 3
    #: Fixed input multipliers (category, x, y, z, filled); see ModelConfig.feature_scale.
    feature_scale: tuple[float, ...] = (1.0, 1.0, 1.0, 1.0, 1.0)
    #: None: the architecture's default (:func:`augmentation_for`).
    augmentation: Augmenter | None = None
    #: Draw fresh augmented copies every this many epochs (0: draw them once; None: the
    #: architecture's default, :func:`resample_every_for`).
    resample_every: int | None = None
    #: How a batch runs through the network (:data:`BATCH_LAYOUTS`): "padded", dense algebra
    #: on complete graphs padded per group of similar sizes; "pyg", the slower reference, PyG
    #: message passing over explicit edges. Same loss and gradients up to float rounding.
    batch_layout: str = "padded"
    #: Where the network trains: "cpu", "cuda" or "cuda:N" (the checkpoint is CPU either way).
    device: str = "cpu"
    #: A task's feature spec (:meth:`FeatureSpec.for_task`); None: the paper's five columns.
    #: :func:`train` sets it from demonstrations that carry attributes or accepts.
    features: FeatureSpec | None = None
    #: How node states become a decision (:data:`~manigraph_planner.gnn.models.config.DECODERS`):
    #: "nodes", the paper's two softmaxes; "pairs", one softmax over (object, goal) pairs.
    decoder: str = "nodes"
    #: The task family whose demonstrations it trains (``manigraph train`` sets it from the
    #: scenes): the augmentation is drawn from its recipes, if it names some; None: from the
    #: fallback's (:func:`~manigraph_training.recipes.recipes`).
    family: str | None = None

    def __post_init__(self) -> None:
        # 0 epochs: the network as initialised, the untrained baseline beside a learned one
        if self.epochs < 0:
            raise ConfigError("epochs", "must be >= 0 (0: the untrained network)")
        if self.batch_size < 1:
            raise ConfigError("batch_size", "must be >= 1")
        self.model_config()  # the architecture and sizes, checked where a network is built
        resample_every = self.resample_every
        if resample_every is None:
            resample_every = resample_every_for(self.architecture, self.family)
            object.__setattr__(self, "resample_every", resample_every)
        if resample_every < 0:
            raise ConfigError("resample_every", "must be >= 0 epochs")
        if self.learning_rate <= 0:
            raise ConfigError("learning_rate", "must be > 0")
        BATCH_LAYOUTS.check(self.batch_layout)
        _check_device(self.device)
        if self.augmentation is None:
            augmentation = augmentation_for(self.architecture, family=self.family)
            object.__setattr__(self, "augmentation", augmentation)

    def model_config(self) -> ModelConfig:
        """The network this trains (``ConfigError`` naming a bad field)."""
        scale = self.feature_scale
        if self.features is not None and len(scale) != self.features.num_features:
            scale = (*scale[:5], *(1.0,) * (self.features.num_features - 5))
        return ModelConfig(
            architecture=self.architecture,
            hidden_channels=self.hidden_channels,
            num_layers=self.num_layers,
            feature_scale=scale,
            features=self.features,
            decoder=self.decoder,
        )

    def for_task(self, spec: FeatureSpec) -> TrainConfig:
        """This config for demonstrations of ``spec``: a task's spec trains with its columns
        and the generic augmentation (:meth:`Augmenter.for_task`); the paper's, as is."""
        if spec.task is None:
            return self
        assert self.augmentation is not None  # set in __post_init__
        return replace(self, features=spec, augmentation=self.augmentation.for_task(spec))

    def to_dict(self) -> dict[str, object]:
        """Plain types (the feature spec is stamped in the checkpoint on its own; the decoder
        only when it is not the paper's)."""
        values = asdict(self)
        values.pop("features")
        if values["decoder"] == "nodes":  # as before there was a choice
            values.pop("decoder")
        if values["family"] is None:  # as before the family chose the recipe
            values.pop("family")
        return values


def _check_device(device: str) -> None:
    if device == "cpu":
        return
    if not re.fullmatch(r"cuda(:\d+)?", device):
        raise ConfigError("device", f"'{device}' is not cpu, cuda or cuda:N")
    if not torch.cuda.is_available():
        raise ConfigError("device", f"{device}: torch sees no CUDA device on this machine")
    index = int(device.partition(":")[2] or 0)
    if index >= torch.cuda.device_count():
        raise ConfigError(
            "device", f"{device}: this machine has {torch.cuda.device_count()} CUDA device(s)"
        )


#: Samples per forward pass in :func:`accuracy`; bounds memory, as a padded GAT batch holds
#: :math:`B N_{max}^2` attention weights.
_ACCURACY_CHUNK = 256


def accuracy(net: PolicyNet, samples: list[Sample], batch_layout: str = "padded") -> float:
    """Fraction of samples where the object and the goal both match the expert's, up to ties.

    The expert breaks ties (blocks at the same height in a box) by id, which no node feature
    shows; a choice with the same category, height and filled flag as the expert's counts.
    """
    layout = BATCH_LAYOUTS[batch_layout]
    net.eval()
    with torch.inference_mode():
        chunks = range(0, len(samples), _ACCURACY_CHUNK)
        choices = [layout.choices(net, samples[i : i + _ACCURACY_CHUNK]) for i in chunks]
    net.train()
    objects, goals = (torch.cat(per_chunk) for per_chunk in zip(*choices, strict=True))
    batch = PaddedBatch.from_samples(samples)
    graphs = torch.arange(batch.num_graphs)
    # category, z, filled and a task's columns: everything but x and y
    columns = [0, *range(3, batch.x.shape[2])]

    def same(chosen: torch.Tensor, expert: torch.Tensor) -> torch.Tensor:
        a, b = batch.x[graphs, chosen][:, columns], batch.x[graphs, expert][:, columns]
        return (chosen >= 0) & torch.isclose(a, b, atol=1e-4).all(dim=1)

    hits = same(objects, batch.object_index) & same(goals, batch.goal_index)
    return float(hits.float().mean())


def train(
    demos: Demonstrations,
    config: TrainConfig,
    progress: TextIO | None = None,
    on_epoch: EpochCallback | None = None,
) -> tuple[PolicyNet, dict[str, object]]:
    """Train a policy on ``demos``; returns it with metrics (loss, accuracy, seconds).

    ``progress``: the stream for a progress bar (epochs, loss, ETA), drawn only if it is a
    terminal (:class:`~manigraph_shared.progress.Progress`); ``on_epoch`` sees every epoch's
    loss.

    Denormal floats are flushed to zero while it runs (:func:`torch.set_flush_denormal`,
    turned off again at the end): as a policy trains, attention weights and gradients decay
    into the denormal range, where CPU arithmetic is many times slower; measured here, a GAT
    epoch went from 0.45 s to 0.72 s within 60 epochs without it, and stayed at 0.45 s with.
    """
    torch.set_flush_denormal(True)
    try:
        with Progress(
            config.epochs,
            f"train {config.architecture} seed {config.seed}",
            unit="epoch",
            stream=progress,
        ) as bar:
            return _train(demos, config, bar, on_epoch)
    finally:
        torch.set_flush_denormal(False)


def _train(
    demos: Demonstrations, config: TrainConfig, bar: Progress, on_epoch: EpochCallback | None
) -> tuple[PolicyNet, dict[str, object]]:
    config = config.for_task(demos.feature_spec)
    torch.manual_seed(config.seed)
    random.seed(config.seed)
    assert config.augmentation is not None  # set in __post_init__
    fresh = draw_epochs(config.epochs, config.resample_every or 0)
    threads = torch.get_num_threads()
    # A daemonic process (a multiprocessing pool's worker) may not start the draw worker.
    forks = "fork" in multiprocessing.get_all_start_methods()
    if len(fresh) == 1 or multiprocessing.current_process().daemon or not forks:
        draws = InlineDraws(config.augmentation, demos.samples, config.seed)
        return _fit(demos, config, draws, set(fresh), bar, on_epoch)
    # The draw worker takes one of the threads this run was given: the small dense layers
    # gain less from a second intra-op thread than the draws do from a core of their own.
    torch.set_num_threads(max(1, threads - 1))
    try:
        with AugmentedDraws(config.augmentation, demos.samples, config.seed, len(fresh)) as bg:
            return _fit(demos, config, bg, set(fresh), bar, on_epoch)
    finally:
        torch.set_num_threads(threads)


def _fit(
    demos: Demonstrations,
    config: TrainConfig,
    draws: Draws,
    fresh: set[int],
    bar: Progress,
    on_epoch: EpochCallback | None,
) -> tuple[PolicyNet, dict[str, object]]:
    samples = PackedSamples.pack(draws.take())
    net = PolicyNet(config.model_config()).to(config.device)
    optimiser = FlatAdam(  # torch.optim.Adam's arithmetic, in one kernel per operation
        net.parameters(), lr=config.learning_rate, weight_decay=config.weight_decay
    )
    schedule = torch.optim.lr_scheduler.CosineAnnealingLR(optimiser, T_max=max(config.epochs, 1))
    layout = BATCH_LAYOUTS[config.batch_layout]
    batches_per_epoch = max(1, (len(samples) + config.batch_size - 1) // config.batch_size)
    started = time.perf_counter()
    order = list(range(len(samples)))
    loss_value = float("nan")
    for epoch in range(1, config.epochs + 1):
        if epoch in fresh and epoch > 1:
            samples = PackedSamples.pack(draws.take())
        random.shuffle(order)
        total = 0.0
        for b in range(batches_per_epoch):
            chunk = order[b * config.batch_size : (b + 1) * config.batch_size]
            loss = layout.packed_loss(net, samples, chunk)
            optimiser.zero_grad()
            loss.backward()
            optimiser.step()
            total += loss.item()
        schedule.step()
        loss_value = total / batches_per_epoch
        bar.status(f"loss {loss_value:.4f}")
        bar.update()
        if on_epoch is not None:
            on_epoch(epoch, loss_value)
    optimiser.unflatten()
    metrics: dict[str, object] = {
        # 0 epochs: no loss was taken, and the checkpoint says the network is untrained
        "final_loss": round(loss_value, 6) if config.epochs else None,
        **({"untrained": True} if config.epochs == 0 else {}),
        "demo_accuracy": round(accuracy(net, demos.samples, config.batch_layout), 4),
        "training_samples": len(samples),
        "demonstration_samples": len(demos.samples),
        "episodes": demos.episodes,
        "train_seconds": round(time.perf_counter() - started, 2),
        "device": config.device,
    }
    return net.cpu(), metrics
