"""GNN policy checkpoints: one ``.pt`` file that says exactly what it holds.

The file is ``torch.save`` of a dict of plain types plus the network's ``state_dict``, so it
loads with ``torch.load(weights_only=True)`` and never runs pickled code:

============================  ==============================================================
key                           value
============================  ==============================================================
``format``                    ``"manigraph.gnn-policy"``
``format_version``            ``1``
``manigraph_version``         version of ``manigraph-planner`` that wrote the file
``model``                     :meth:`ModelConfig.to_dict` (architecture, sizes, scaling)
``feature_spec``              :meth:`FeatureSpec.to_dict` of the features trained on
``training_config``           the trainer's settings, plain types
``data_hash``                 identifies the training data (e.g. a SHA-256 of the dataset)
``metrics``                   plain-typed dict, or None
``state_dict``                the network's parameters
============================  ==============================================================

Loading refuses, with a :class:`PolicyError` naming the field, anything that is not such a
file, names an unknown architecture, or was built for a different feature spec; and, before
paying for it, an archive, a declared network or a vocabulary beyond what
:mod:`.checkpoint_limits` allows, or weights that are not finite.
"""

from __future__ import annotations

import os
import pickle
import zipfile
from collections.abc import Mapping
from dataclasses import dataclass
from importlib.metadata import PackageNotFoundError, version
from pathlib import Path
from typing import Any, NamedTuple

import torch

from manigraph_planner.gnn import checkpoint_limits as limits
from manigraph_planner.gnn.features import FeatureSpec
from manigraph_planner.gnn.models import ModelConfig, PolicyNet
from manigraph_planner.gnn.models.build import policy_net_for
from manigraph_shared.errors import ConfigError, PolicyError

__all__ = ["CheckpointInfo", "LoadedCheckpoint", "load_checkpoint", "save_checkpoint"]

FORMAT = "manigraph.gnn-policy"
#: What the refusal of a file that is not a checkpoint at all starts with.
NOT_A_CHECKPOINT = "not a manigraph checkpoint"
FORMAT_VERSION = 1
_FIELDS: dict[str, type | tuple[type, ...]] = {
    "format": str,
    "format_version": int,
    "manigraph_version": str,
    "model": dict,
    "feature_spec": dict,
    "training_config": dict,
    "data_hash": str,
    "metrics": (dict, type(None)),
    "state_dict": dict,
}


@dataclass(frozen=True)
class CheckpointInfo:
    """Everything a checkpoint records besides the weights."""

    model: ModelConfig
    feature_spec: dict[str, Any]
    training_config: dict[str, Any]
    data_hash: str
    manigraph_version: str
    metrics: dict[str, Any] | None

    @property
    def architecture(self) -> str:
        return self.model.architecture


class LoadedCheckpoint(NamedTuple):
    net: PolicyNet
    info: CheckpointInfo


def manigraph_version() -> str:
    try:
        return version("manigraph-planner")
    except PackageNotFoundError:  # running from a source tree that was never installed
        return "unknown"


def save_checkpoint(
    path: str | os.PathLike[str],
    net: PolicyNet,
    *,
    training_config: dict[str, Any],
    data_hash: str,
    metrics: dict[str, Any] | None = None,
) -> Path:
    """Write ``net`` and its provenance to ``path`` atomically (temp file, then rename).

    Raises:
        ValueError: ``training_config`` or ``metrics`` holds something other than plain
            types (str, int, float, bool, None, lists/tuples and str-keyed dicts of them),
            or ``data_hash`` is empty.
    """
    _check_plain(training_config, "training_config")
    if metrics is not None:
        _check_plain(metrics, "metrics")
    if not isinstance(data_hash, str) or not data_hash:
        raise ValueError("data_hash: must be a non-empty string")
    payload = {
        "format": FORMAT,
        "format_version": FORMAT_VERSION,
        "manigraph_version": manigraph_version(),
        "model": net.config.to_dict(),
        "feature_spec": net.config.feature_spec.to_dict(),
        "training_config": training_config,
        "data_hash": data_hash,
        "metrics": metrics,
        "state_dict": {k: v.detach().cpu().clone() for k, v in net.state_dict().items()},
    }
    target = Path(path)
    partial = target.with_name(f".{target.name}.partial")
    torch.save(payload, partial)
    os.replace(partial, target)
    return target


def load_checkpoint(path: str | os.PathLike[str], message_passing: bool = True) -> LoadedCheckpoint:
    """The network (in eval mode) and provenance stored in ``path``; with
    ``message_passing=False`` a network of the layers' weights only, for the dense inference
    path, built without importing PyG (:mod:`~manigraph_planner.gnn.models.layer_weights`).

    Raises:
        PolicyError: the file is unreadable or not a manigraph GNN checkpoint at all (``not
            a manigraph checkpoint: <path>: <why>``), its architecture is not registered,
            its feature spec differs from this code's, or its weights do not fit its
            architecture; or before reading or building more than it may, the archive, the
            declared sizes or a vocabulary's order are beyond :mod:`.checkpoint_limits`, or
            a weight is NaN or infinite. One line, naming the field (and the limit).
    """
    payload = _read_payload(Path(path))
    _check_envelope(payload, path)
    limits.check_feature_columns(payload["feature_spec"])
    task_spec = _task_feature_spec(payload["feature_spec"], payload["model"])
    model = _model_config(payload["model"], task_spec)
    limits.check_declared_sizes(model)
    _check_feature_spec(payload["feature_spec"], model.feature_spec)
    # Shapes first, from a network on the meta device: what is built below is then no
    # bigger than what the (size-checked) archive stored.
    _refuse_misfit(model, _state_dict_problem(limits.expected_state(model), payload["state_dict"]))
    limits.check_finite(payload["state_dict"])
    net = policy_net_for(model, message_passing)
    _refuse_misfit(model, _state_dict_problem(net.state_dict(), payload["state_dict"]))
    net.load_state_dict(payload["state_dict"], strict=True)
    net.eval()
    info = CheckpointInfo(
        model=model,
        feature_spec=payload["feature_spec"],
        training_config=payload["training_config"],
        data_hash=payload["data_hash"],
        manigraph_version=payload["manigraph_version"],
        metrics=payload["metrics"],
    )
    return LoadedCheckpoint(net, info)


def _refuse_misfit(model: ModelConfig, problem: str) -> None:
    if problem:
        raise PolicyError(
            f"checkpoint state_dict: does not fit architecture '{model.architecture}' "
            f"(hidden_channels={model.hidden_channels}, num_layers={model.num_layers}): {problem}"
        )


def _read_payload(path: Path) -> Any:
    """What ``torch.save`` wrote to ``path``; a :class:`PolicyError` saying ``not a manigraph
    checkpoint: <path>: <why>`` for anything else (torch.load's own errors on a text file,
    such as ``KeyError: 101``, say nothing a user can act on)."""
    if not path.exists():
        raise PolicyError(f"checkpoint: no such file: {path}")
    try:
        with path.open("rb") as stream:
            head = stream.read(512)
    except OSError as exc:
        raise PolicyError(f"checkpoint: cannot read {path}: {exc.strerror or exc}") from None
    if not zipfile.is_zipfile(path):  # what torch.save writes, since torch 1.6
        raise PolicyError(f"{NOT_A_CHECKPOINT}: {path}: {_what_it_holds(head)}")
    # torch.load raises a zoo of types on a broken archive (UnpicklingError, RuntimeError from
    # the zip reader, EOFError, ...); all of them mean the same thing here. The archive that
    # was size-checked is the one read: one open file for both.
    try:
        with path.open("rb") as stream:
            limits.check_archive(stream, path)
            stream.seek(0)
            return torch.load(stream, map_location="cpu", weights_only=True)
    except PolicyError:
        raise
    except Exception as exc:
        if isinstance(exc, pickle.UnpicklingError):
            why = "it holds pickled objects beyond plain types and tensors"
        elif isinstance(exc, EOFError):
            why = "the file ends early: truncated"
        else:
            why = f"{type(exc).__name__}: {_first_sentence(exc)}"
        raise PolicyError(f"{NOT_A_CHECKPOINT}: {path}: {why}") from exc


def _what_it_holds(head: bytes) -> str:
    """Why a file starting with ``head`` is no archive of ``torch.save``'s, in words."""
    if not head:
        return "the file is empty"
    try:
        head.decode("utf-8")
    except UnicodeDecodeError:
        return "its bytes are not an archive torch.save writes"
    return "a text file, not an archive torch.save writes"


def _check_envelope(payload: Any, path: str | os.PathLike[str]) -> None:
    if not isinstance(payload, dict):
        raise PolicyError(
            f"{NOT_A_CHECKPOINT}: {path}: it holds a {type(payload).__name__}, not a dict"
        )
    if payload.get("format") != FORMAT:
        raise PolicyError(
            f"{NOT_A_CHECKPOINT}: {path}: its format is {payload.get('format')!r}, not {FORMAT!r}"
        )
    if payload.get("format_version") != FORMAT_VERSION:
        raise PolicyError(
            f"checkpoint format_version: file has {payload.get('format_version')!r} but this "
            f"manigraph reads {FORMAT_VERSION}"
        )
    missing = [key for key in _FIELDS if key not in payload]
    if missing:
        raise PolicyError(f"checkpoint {missing[0]}: missing (missing keys: {missing})")
    unknown = sorted(str(key) for key in payload if key not in _FIELDS)
    if unknown:
        raise PolicyError(f"checkpoint {unknown[0]}: unexpected key (unexpected: {unknown})")
    for key, expected in _FIELDS.items():
        if not isinstance(payload[key], expected):
            raise PolicyError(
                f"checkpoint {key}: expected {_type_names(expected)}, "
                f"file has {type(payload[key]).__name__}"
            )


def _task_feature_spec(stored: dict[str, Any], model: dict[str, Any]) -> FeatureSpec | None:
    """The task's spec a checkpoint stamps (``feature_spec.task``), or None: the heads'."""
    if "task" not in stored:
        return None
    if model.get("heads", "object-goal") != "object-goal":
        raise PolicyError("checkpoint feature_spec.task: only 'object-goal' heads take one")
    try:
        spec = FeatureSpec.from_dict(stored)
    except (TypeError, ValueError) as exc:
        raise PolicyError(f"checkpoint feature_spec.{exc}") from None
    assert spec.task is not None  # "task" in stored
    limits.check_vocabulary_order(spec.task)
    return spec


def _check_feature_spec(stored: dict[str, Any], spec: FeatureSpec) -> None:
    """``stored`` must be ``spec``: the one this code builds for the checkpoint's heads, or
    the task's spec it stamps."""
    expected = spec.to_dict()
    for key in sorted(set(stored) | set(expected)):
        if key not in expected:
            raise PolicyError(f"checkpoint feature_spec.{key}: unexpected key")
        if key not in stored:
            raise PolicyError(f"checkpoint feature_spec.{key}: missing")
        have, want = stored[key], expected[key]
        if key == "task":
            continue  # read back by FeatureSpec.from_dict, which checked it whole
        if isinstance(want, list):
            have, want = tuple(have) if isinstance(have, list | tuple) else have, tuple(want)
        if have != want:
            raise PolicyError(
                f"checkpoint feature_spec.{key}: file has {have!r} but this manigraph "
                f"expects {want!r}"
            )


def _model_config(stored: dict[str, Any], features: FeatureSpec | None = None) -> ModelConfig:
    try:
        return ModelConfig.from_dict(stored, features)
    except ConfigError as exc:
        raise PolicyError(f"checkpoint model.{exc}") from exc
    except TypeError as exc:  # a value of a type the dataclass cannot even compare
        raise PolicyError(f"checkpoint model: {exc}") from exc


def _check_plain(value: Any, where: str) -> None:
    if value is None or isinstance(value, str | int | float | bool):
        return
    if isinstance(value, list | tuple):
        for index, item in enumerate(value):
            _check_plain(item, f"{where}[{index}]")
        return
    if isinstance(value, dict):
        for key, item in value.items():
            if not isinstance(key, str):
                raise ValueError(f"{where}: keys must be str, got {key!r}")
            _check_plain(item, f"{where}.{key}")
        return
    raise ValueError(f"{where}: {type(value).__name__} is not a plain type")


def _type_names(expected: type | tuple[type, ...]) -> str:
    types = expected if isinstance(expected, tuple) else (expected,)
    return " or ".join("None" if t is type(None) else t.__name__ for t in types)


def _state_dict_problem(expected: Mapping[str, torch.Tensor], stored: dict[str, Any]) -> str:
    """The first way ``stored`` does not fit a network whose state is ``expected``, or
    ``""``."""
    missing = [key for key in expected if key not in stored]
    if missing:
        return f"missing {missing[:3]}"
    unexpected = [str(key) for key in stored if key not in expected]
    if unexpected:
        return f"unexpected {unexpected[:3]}"
    for key, value in stored.items():
        if not isinstance(value, torch.Tensor) or value.shape != expected[key].shape:
            have = tuple(value.shape) if isinstance(value, torch.Tensor) else type(value).__name__
            return f"{key} has shape {have}, expected {tuple(expected[key].shape)}"
        if value.layout != torch.strided:
            return f"{key} is a {value.layout} tensor, expected a dense one"
    return ""


def _first_sentence(exc: BaseException) -> str:
    text = str(exc).strip()
    return text.split(". ")[0].splitlines()[0] if text else "no detail"
