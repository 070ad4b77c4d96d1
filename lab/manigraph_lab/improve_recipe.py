"""A checkpoint's own training recipe, read back from what it stamps (``training_config``).

``manigraph train`` stamps every setting of its :class:`TrainConfig` (the augmentation with
its geometry included) and the demonstrations it read. ``manigraph improve`` retrains with
exactly those, so the settings are rebuilt here field by field: a key this code does not
know means the recipe cannot be repeated, and is refused naming it rather than dropped.
"""

from __future__ import annotations

import dataclasses
import typing
from pathlib import Path
from typing import Any

from manigraph_shared.errors import ConfigError, PolicyError
from manigraph_training.recipes import augmentation_for
from manigraph_training.trainer import TrainConfig


def recipe_of(training_config: dict[str, Any], source: str, device: str = "cpu") -> TrainConfig:
    """The :class:`TrainConfig` a checkpoint at ``source`` was trained with, to train on
    ``device`` (where it trains changes nothing it learns); ``PolicyError`` naming the key
    that cannot be read back."""
    values = {key: value for key, value in training_config.items() if key != "demos"}
    values["device"] = device
    try:
        augmentation = values.get("augmentation")
        if isinstance(augmentation, dict):  # of the type its architecture's recipe draws with
            kind = type(augmentation_for(str(values.get("architecture", TrainConfig.architecture))))
            values["augmentation"] = _build(kind, augmentation, "training_config.augmentation")
        return typing.cast(TrainConfig, _build(TrainConfig, values, "training_config"))
    except (ConfigError, ValueError, TypeError) as exc:
        raise PolicyError(f"{source}: its training recipe cannot be repeated: {exc}") from None


def demos_of(training_config: dict[str, Any], source: str) -> list[Path]:
    """The demonstrations a checkpoint names (``training_config.demos``)."""
    demos = training_config.get("demos")
    if not isinstance(demos, list) or not demos or not all(isinstance(d, str) for d in demos):
        raise PolicyError(
            f"{source}: its training_config names no demonstrations (demos), so its data "
            "cannot be added to: train it with `manigraph train`"
        )
    return [Path(d) for d in demos]


def _build(cls: type, values: Any, where: str) -> Any:
    """``cls`` (a dataclass) from the plain ``values`` it was stamped as."""
    if not isinstance(values, dict):
        raise ValueError(f"{where}: expected a table, found {type(values).__name__}")
    hints = typing.get_type_hints(cls)
    known = {f.name for f in dataclasses.fields(cls) if f.init}
    unknown = sorted(set(values) - known)
    if unknown:
        raise ValueError(f"{where}.{unknown[0]}: a setting this manigraph does not know")
    kwargs: dict[str, Any] = {}
    for name, value in values.items():
        kwargs[name] = _value(hints[name], value, f"{where}.{name}")
    return cls(**kwargs)


def _value(hint: Any, value: Any, where: str) -> Any:
    if value is None:
        return None
    nested = _dataclass_in(hint)
    if nested is not None:
        return _build(nested, value, where)
    if isinstance(value, list):  # tuples are stamped as lists
        return tuple(tuple(v) if isinstance(v, list) else v for v in value)
    return value


def _dataclass_in(hint: Any) -> type | None:
    """The dataclass ``hint`` names (``X`` or ``X | None``), else None."""
    for candidate in (hint, *typing.get_args(hint)):
        if isinstance(candidate, type) and dataclasses.is_dataclass(candidate):
            return candidate
    return None
