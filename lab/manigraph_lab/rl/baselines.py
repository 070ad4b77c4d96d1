"""The paper's four RL baselines, registered by name, trained stage by stage with PPO.

======================  ==================================================================
baseline                stages (each ``steps_per_stage`` environment interactions)
======================  ==================================================================
``rl-mlp``              one fresh MLP policy per K = 2..9 (fixed-size input), evaluated at
                        its own K
``rl-gnn``              one GNN policy on episodes of K drawn from 2..9 (mixed), trained in
                        8 equal parts; the last part is evaluated at every K
``rl-gnn-seq``          the curriculum: K = 2, then 3, ... 9, each stage starting from the
                        previous one; the stage-K policy is evaluated at K
``rl-gnn-demo``         ``rl-gnn-seq`` plus the auxiliary imitation loss
                        (:mod:`manigraph_lab.rl.imitation`) on the expert demonstrations
======================  ==================================================================

PPO is ``sb3_contrib.MaskablePPO`` (stable-baselines3) with the env's action mask; the GNN is
the planner's :class:`~manigraph_planner.gnn.models.PolicyNet` (:mod:`.policies`).
"""

from __future__ import annotations

import time
from abc import ABC, abstractmethod
from collections.abc import Callable, Sequence
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from sb3_contrib import MaskablePPO
from stable_baselines3.common.monitor import Monitor

from manigraph_lab.rl.env import StackEnv
from manigraph_lab.rl.imitation import ImitationAdam, ImitationTerm
from manigraph_lab.rl.policies import (
    GraphActorCriticPolicy,
    MaskablePPOPolicy,
    as_gnn_policy,
    policy_net,
)
from manigraph_planner.gnn.models import ARCHITECTURES
from manigraph_planner.policies.base import Policy
from manigraph_shared.errors import ConfigError
from manigraph_shared.registry import Registry
from manigraph_training.dataset import Sample

__all__ = ["BASELINES", "Baseline", "PPOSettings", "Stage", "register_baseline", "train_stage"]


@dataclass(frozen=True)
class PPOSettings:
    """PPO, network and budget settings shared by every baseline.

    Args:
        steps_per_stage: environment interactions per stage (the paper: 2,000 per K).
        blocks: the K of the comparison (the paper: 2..9).
        n_steps, batch_size, n_epochs, learning_rate, gamma, gae_lambda, ent_coef: PPO's.
        architecture, hidden_channels, num_layers: the GNN (the paper: 3 x 64); the MLP has
            ``num_layers`` hidden layers of ``hidden_channels`` too.
        imitation_weight: :math:`\\lambda_{IL}` of ``rl-gnn-demo``.
        imitation_batch: expert samples per gradient step of ``rl-gnn-demo``.

    Raises:
        ConfigError: naming the offending field.
    """

    steps_per_stage: int = 2000
    blocks: tuple[int, ...] = tuple(range(2, 10))
    n_steps: int = 250
    batch_size: int = 50
    n_epochs: int = 4
    learning_rate: float = 1e-3
    gamma: float = 0.99
    gae_lambda: float = 0.95
    ent_coef: float = 0.01
    architecture: str = "sage"
    hidden_channels: int = 64
    num_layers: int = 3
    imitation_weight: float = 1.0
    imitation_batch: int = 32

    def __post_init__(self) -> None:
        for name in ("steps_per_stage", "n_steps", "batch_size", "n_epochs", "imitation_batch"):
            if getattr(self, name) < 1:
                raise ConfigError(name, f"must be >= 1, got {getattr(self, name)}")
        if self.steps_per_stage % self.n_steps:
            raise ConfigError(
                "steps_per_stage",
                f"must be a multiple of n_steps={self.n_steps}, got {self.steps_per_stage}",
            )
        if not self.blocks or min(self.blocks) < 1 or max(self.blocks) > 64:
            raise ConfigError("blocks", f"each K must be in 1..64, got {self.blocks}")
        if self.architecture not in ARCHITECTURES:
            raise ConfigError("architecture", f"'{self.architecture}' is not registered")
        if self.imitation_weight < 0:
            raise ConfigError("imitation_weight", f"must be >= 0, got {self.imitation_weight}")

    def ppo_kwargs(self) -> dict[str, Any]:
        return {
            "n_steps": self.n_steps,
            "batch_size": self.batch_size,
            "n_epochs": self.n_epochs,
            "learning_rate": self.learning_rate,
            "gamma": self.gamma,
            "gae_lambda": self.gae_lambda,
            "ent_coef": self.ent_coef,
        }

    def to_dict(self) -> dict[str, Any]:
        values = asdict(self)
        values["blocks"] = list(self.blocks)
        return values


@dataclass(frozen=True)
class Stage:
    """One saved step of a baseline's training.

    Args:
        name: file-safe name, unique within the baseline (``K3``, ``part2``).
        blocks: the K (one, or several drawn per episode) the stage trains on.
        evaluate_on: the K at which this stage's policy is evaluated (none: an intermediate).
    """

    name: str
    blocks: tuple[int, ...]
    evaluate_on: tuple[int, ...] = field(default=())


#: Called for the expert samples when a baseline needs them (loaded once, lazily).
DemoSource = Callable[[], Sequence[Sample]]


class Baseline(ABC):
    """One of the paper's RL baselines: its stages, its env, its model, its policy."""

    name: str
    #: Whether each stage starts from the previous stage's model (else from scratch).
    continues: bool = True

    @abstractmethod
    def stages(self, settings: PPOSettings) -> list[Stage]: ...

    def make_env(self, stage: Stage, settings: PPOSettings) -> StackEnv:
        """GNN baselines share one slot size, so a model moves between stages unchanged."""
        return StackEnv(stage.blocks, max_blocks=max(settings.blocks))

    def new_model(self, env: Any, settings: PPOSettings, seed: int) -> MaskablePPO:
        return MaskablePPO(
            GraphActorCriticPolicy,
            env,
            seed=seed,
            device="cpu",
            verbose=0,
            policy_kwargs={
                "features_extractor_kwargs": {
                    "architecture": settings.architecture,
                    "hidden_channels": settings.hidden_channels,
                    "num_layers": settings.num_layers,
                },
                "optimizer_class": ImitationAdam,
            },
            **settings.ppo_kwargs(),
        )

    def prepare(
        self, model: MaskablePPO, settings: PPOSettings, seed: int, demos: DemoSource
    ) -> None:
        """Called before each stage trains (after a new model is made or a saved one loaded)."""

    def policy(self, model: MaskablePPO, env: StackEnv) -> Policy:
        """The trained model as a planner policy, for evaluation."""
        gnn = as_gnn_policy(model)
        gnn.name = self.name
        return gnn


#: Every baseline by name, one instance each (the one ``Registry`` every swapped part uses).
BASELINES: Registry[Baseline] = Registry("baseline")


def register_baseline(name: str) -> Callable[[type[Baseline]], type[Baseline]]:
    """Register one instance of the decorated class as ``name``; a second entry under a name
    is refused (``ConfigError``, a ``ValueError``)."""

    def register(cls: type[Baseline]) -> type[Baseline]:
        cls.name = name
        BASELINES.add(name, cls())
        return cls

    return register


@register_baseline("rl-mlp")
class MLPBaseline(Baseline):
    """An MLP on the flattened slots, retrained from scratch for every K."""

    continues = False

    def stages(self, settings: PPOSettings) -> list[Stage]:
        return [Stage(f"K{k}", (k,), (k,)) for k in settings.blocks]

    def make_env(self, stage: Stage, settings: PPOSettings) -> StackEnv:
        return StackEnv(stage.blocks)  # input sized for exactly this K

    def new_model(self, env: Any, settings: PPOSettings, seed: int) -> MaskablePPO:
        width = [settings.hidden_channels] * settings.num_layers
        return MaskablePPO(
            "MultiInputPolicy",
            env,
            seed=seed,
            device="cpu",
            verbose=0,
            policy_kwargs={"net_arch": {"pi": width, "vf": width}},
            **settings.ppo_kwargs(),
        )

    def policy(self, model: MaskablePPO, env: StackEnv) -> Policy:
        return MaskablePPOPolicy(model, env.layout, self.name)


@register_baseline("rl-gnn")
class GNNBaseline(Baseline):
    """One GNN on a mix of every K, in as many equal parts as there are K."""

    def stages(self, settings: PPOSettings) -> list[Stage]:
        parts = len(settings.blocks)
        return [
            Stage(f"part{i + 1}", settings.blocks, settings.blocks if i == parts - 1 else ())
            for i in range(parts)
        ]


@register_baseline("rl-gnn-seq")
class SequentialGNNBaseline(Baseline):
    """The curriculum of Li et al. (2020): K = 2 first, each next K from the previous policy."""

    def stages(self, settings: PPOSettings) -> list[Stage]:
        return [Stage(f"K{k}", (k,), (k,)) for k in sorted(settings.blocks)]


@register_baseline("rl-gnn-demo")
class DemoGNNBaseline(SequentialGNNBaseline):
    """The curriculum plus :math:`\\lambda_{IL}` times the IL cross-entropy on expert demos."""

    def prepare(
        self, model: MaskablePPO, settings: PPOSettings, seed: int, demos: DemoSource
    ) -> None:
        optimizer = model.policy.optimizer
        if not isinstance(optimizer, ImitationAdam):
            raise TypeError("rl-gnn-demo: the model's optimizer is not ImitationAdam")
        optimizer.imitation = ImitationTerm(
            policy_net(model), demos(), settings.imitation_weight, settings.imitation_batch, seed
        )


def train_stage(
    baseline: Baseline,
    stage: Stage,
    settings: PPOSettings,
    seed: int,
    previous: Path | None,
    output: Path,
    demos: DemoSource,
) -> dict[str, Any]:
    """Train one stage and save its model to ``output`` (a ``.zip``); returns its record.

    ``previous`` is the saved model to start from (None: a new model). The stage's seed
    (model, env resets, minibatches) depends on ``seed`` and the stage only, so a stage
    trained after a resume is the stage an uninterrupted run trains.
    """
    index = [s.name for s in baseline.stages(settings)].index(stage.name)
    stage_seed = 1000 * seed + index
    env = Monitor(baseline.make_env(stage, settings))
    if previous is None:
        model = baseline.new_model(env, settings, stage_seed)
    else:
        model = MaskablePPO.load(previous, env=env, device="cpu")
        model.set_random_seed(stage_seed)
    baseline.prepare(model, settings, stage_seed, demos)
    started = time.perf_counter()
    model.learn(settings.steps_per_stage, reset_num_timesteps=previous is None)
    seconds = time.perf_counter() - started
    output.parent.mkdir(parents=True, exist_ok=True)
    model.save(output)
    returns = [float(info["r"]) for info in model.ep_info_buffer or []]
    record: dict[str, Any] = {
        "baseline": baseline.name,
        "seed": seed,
        "stage": stage.name,
        "blocks": list(stage.blocks),
        "timesteps": settings.steps_per_stage,
        "total_timesteps": int(model.num_timesteps),
        "seconds": round(seconds, 2),
        "recent_episodes": len(returns),
        "recent_mean_return": round(float(np.mean(returns)), 4) if returns else None,
        "recent_success_rate": round(float(np.mean(model.ep_success_buffer)), 4)
        if model.ep_success_buffer
        else None,
    }
    optimizer = model.policy.optimizer
    if isinstance(optimizer, ImitationAdam) and optimizer.imitation is not None:
        losses = optimizer.imitation.losses
        record["imitation_loss_first"] = round(losses[0], 4) if losses else None
        record["imitation_loss_last"] = round(losses[-1], 4) if losses else None
    return record


def load_model(path: Path, env: Any) -> MaskablePPO:
    """A saved stage, for evaluation."""
    return MaskablePPO.load(path, env=env, device="cpu")
