"""Which GNN policy to build: architecture name and sizes, validated once."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

from manigraph_planner.family import FAMILIES, family_for_heads
from manigraph_planner.gnn.features import FEATURE_SPEC, FeatureSpec
from manigraph_planner.gnn.models.backbone import ARCHITECTURES
from manigraph_shared.errors import ConfigError
from manigraph_shared.registry import Registry

__all__ = ["DECODERS", "HEADS", "ModelConfig", "feature_spec_for"]

#: How node states become a decision (``ModelConfig.decoder``): ``nodes``, the paper's two
#: independent softmaxes (objects, goals) over the node logits; ``pairs``, one softmax over
#: the compatible (object, goal) pairs, each scored from both nodes' states
#: (:class:`~manigraph_planner.gnn.models.pair_head.PairHead`), so the goal is picked given
#: the object (docs/training.md, "A decoder over pairs").
DECODERS = ("nodes", "pairs")

#: The policy's output heads -> the feature spec its graph states are built with.
#: ``object-goal``: the paper's node logits (object and goal), over the paper's five columns
#: (or a task file's, stamped in the checkpoint). A task family with heads of its own
#: (``PlannerFamily.heads``) points at its package's spec,
#: imported when first used.
#: The families' heads are added when it is first read.


def _add_family_heads() -> None:
    for name, family in FAMILIES.items():
        if family.heads not in HEADS.names() and family.feature_spec is not None:
            HEADS.add_lazy(family.heads, family.feature_spec, help=f"the {name} family's")


HEADS: Registry[FeatureSpec] = Registry("heads", fill=_add_family_heads)
HEADS.add("object-goal", FEATURE_SPEC)


def feature_spec_for(heads: str) -> FeatureSpec:
    if heads not in HEADS:
        raise ConfigError("heads", f"'{heads}' is not one of {', '.join(HEADS)}")
    return HEADS[heads]


@dataclass(frozen=True)
class ModelConfig:
    """Hyper-parameters of a :class:`~manigraph_planner.gnn.models.PolicyNet`.

    Args:
        architecture: a registered architecture (``gcn``, ``sage``, ``gated``, ``gat``).
        hidden_channels: units per hidden layer (the paper: 64).
        num_layers: message-passing layers (the paper: 3).
        in_channels: node feature size; must match the heads' feature spec (5 for
            ``object-goal``; default: that size).
        feature_scale: fixed, non-learned per-feature multipliers applied before the first
            layer. All ones (the default) feeds the paper's raw features; e.g.
            ``(1, 10, 10, 10, 1)`` would express positions in decimetres. Recorded in the
            checkpoint so inference scales exactly like training. Default: all ones.
        heads: ``object-goal`` (the block tasks) or a family's own (:data:`HEADS`).
        ensemble: independently trained members whose logits are averaged (heads of a
            family whose networks may be ensembles, ``PlannerFamily.ensembles``; 1, the
            default, is one plain network).
        features: a task's feature spec (:meth:`FeatureSpec.for_task`, ``object-goal`` heads
            only); None, the heads' own. Not in :meth:`to_dict`: the checkpoint stamps it as
            its ``feature_spec`` and :meth:`from_dict` takes it back from there.
        decoder: one of :data:`DECODERS` (``object-goal`` heads only for ``pairs``); the
            default ``nodes`` is the paper's, and what every checkpoint without the key holds.

    Raises:
        ConfigError: (a ``ValueError``) naming the offending field.
    """

    architecture: str
    hidden_channels: int = 64
    num_layers: int = 3
    in_channels: int | None = None
    feature_scale: tuple[float, ...] | None = None
    heads: str = "object-goal"
    ensemble: int = 1
    features: FeatureSpec | None = None
    decoder: str = "nodes"

    @property
    def feature_spec(self) -> FeatureSpec:
        """What the network's input columns mean: ``features``, else the heads' spec."""
        return self.features if self.features is not None else feature_spec_for(self.heads)

    @property
    def input_size(self) -> int:
        """``in_channels``, resolved from the heads' feature spec when it was not given."""
        assert self.in_channels is not None  # __post_init__ resolved it
        return self.in_channels

    def __post_init__(self) -> None:
        ARCHITECTURES.check(self.architecture)  # ConfigError naming the registered ones
        spec = feature_spec_for(self.heads)
        if self.features is not None:
            if self.heads != "object-goal":
                raise ConfigError("features", "only 'object-goal' heads take a task's spec")
            spec = self.features
        if self.in_channels is None:
            object.__setattr__(self, "in_channels", spec.num_features)
        if self.feature_scale is None:
            object.__setattr__(self, "feature_scale", (1.0,) * spec.num_features)
        for name in ("hidden_channels", "num_layers", "in_channels", "ensemble"):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, int) or not 1 <= value <= 4096:
                raise ConfigError(name, f"must be an integer in [1, 4096], got {value!r}")
        if self.in_channels != spec.num_features:
            raise ConfigError(
                "in_channels",
                f"must equal the feature spec's {spec.num_features} features, "
                f"got {self.in_channels}",
            )
        if self.decoder not in DECODERS:
            raise ConfigError("decoder", f"'{self.decoder}' is not one of {', '.join(DECODERS)}")
        if self.decoder != "nodes" and self.heads != "object-goal":
            raise ConfigError(
                "decoder", f"only 'object-goal' heads decode pairs, not {self.heads!r}"
            )
        if self.ensemble > 1 and not family_for_heads(self.heads).ensembles:
            with_members = [f.heads for _, f in FAMILIES.items() if f.ensembles]
            raise ConfigError(
                "ensemble",
                f"only {', '.join(repr(h) for h in with_members)} heads have members, "
                f"not {self.heads!r}",
            )
        assert self.feature_scale is not None
        scale = tuple(self.feature_scale)
        if len(scale) != self.in_channels or not all(
            isinstance(s, int | float) and math.isfinite(s) and s != 0 for s in scale
        ):
            raise ConfigError(
                "feature_scale",
                f"must be {self.in_channels} finite non-zero numbers, got {self.feature_scale!r}",
            )
        object.__setattr__(self, "feature_scale", tuple(float(s) for s in scale))

    def to_dict(self) -> dict[str, Any]:
        """Plain types only, for checkpoints (``ensemble`` only when above 1 and ``decoder``
        only when not ``nodes``, so such a network's file is what it was before either)."""
        values: dict[str, Any] = {
            "architecture": self.architecture,
            "hidden_channels": self.hidden_channels,
            "num_layers": self.num_layers,
            "in_channels": self.in_channels,
            "feature_scale": list(self.feature_scale or ()),
            "heads": self.heads,
        }
        if self.ensemble > 1:
            values["ensemble"] = self.ensemble
        if self.decoder != "nodes":
            values["decoder"] = self.decoder
        return values

    @classmethod
    def from_dict(cls, values: dict[str, Any], features: FeatureSpec | None = None) -> ModelConfig:
        """Inverse of :meth:`to_dict` (``features``: the checkpoint's task spec); unknown or
        missing keys raise ``ConfigError``."""
        fields = set(cls.__dataclass_fields__)
        unknown = sorted(set(values) - fields)
        if unknown:
            raise ConfigError(unknown[0], f"unknown field (known: {', '.join(sorted(fields))})")
        if "architecture" not in values:
            raise ConfigError("architecture", "missing")
        if "features" in values:
            raise ConfigError("features", "unknown field (the spec is the checkpoint's own)")
        kwargs = dict(values)
        if features is not None:
            kwargs["features"] = features
        if "feature_scale" in kwargs and isinstance(kwargs["feature_scale"], list | tuple):
            kwargs["feature_scale"] = tuple(kwargs["feature_scale"])
        return cls(**kwargs)
