"""Which GNN policy to build: architecture name and sizes, validated once."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

from manigraph_planner.gnn.features import FEATURE_SPEC
from manigraph_planner.gnn.models.backbone import ARCHITECTURES
from manigraph_shared.errors import ConfigError

__all__ = ["ModelConfig"]


@dataclass(frozen=True)
class ModelConfig:
    """Hyper-parameters of a :class:`~manigraph_planner.gnn.models.PolicyNet`.

    Args:
        architecture: a registered architecture (``gcn``, ``sage``, ``gated``, ``gat``).
        hidden_channels: units per hidden layer (the paper: 64).
        num_layers: message-passing layers (the paper: 3).
        in_channels: node feature size; must match the feature spec (5).
        feature_scale: fixed, non-learned per-feature multipliers applied before the first
            layer. All ones (the default) feeds the paper's raw features; e.g.
            ``(1, 10, 10, 10, 1)`` would express positions in decimetres. Recorded in the
            checkpoint so inference scales exactly like training.

    Raises:
        ConfigError: (a ``ValueError``) naming the offending field.
    """

    architecture: str
    hidden_channels: int = 64
    num_layers: int = 3
    in_channels: int = FEATURE_SPEC.num_features
    feature_scale: tuple[float, ...] = (1.0,) * FEATURE_SPEC.num_features

    def __post_init__(self) -> None:
        ARCHITECTURES.check(self.architecture)  # ConfigError naming the registered ones
        for name in ("hidden_channels", "num_layers", "in_channels"):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, int) or not 1 <= value <= 4096:
                raise ConfigError(name, f"must be an integer in [1, 4096], got {value!r}")
        if self.in_channels != FEATURE_SPEC.num_features:
            raise ConfigError(
                "in_channels",
                f"must equal the feature spec's {FEATURE_SPEC.num_features} features, "
                f"got {self.in_channels}",
            )
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
        """Plain types only, for checkpoints."""
        return {
            "architecture": self.architecture,
            "hidden_channels": self.hidden_channels,
            "num_layers": self.num_layers,
            "in_channels": self.in_channels,
            "feature_scale": list(self.feature_scale),
        }

    @classmethod
    def from_dict(cls, values: dict[str, Any]) -> ModelConfig:
        """Inverse of :meth:`to_dict`; unknown or missing keys raise ``ConfigError``."""
        fields = set(cls.__dataclass_fields__)
        unknown = sorted(set(values) - fields)
        if unknown:
            raise ConfigError(unknown[0], f"unknown field (known: {', '.join(sorted(fields))})")
        if "architecture" not in values:
            raise ConfigError("architecture", "missing")
        kwargs = dict(values)
        if "feature_scale" in kwargs and isinstance(kwargs["feature_scale"], list | tuple):
            kwargs["feature_scale"] = tuple(kwargs["feature_scale"])
        return cls(**kwargs)
