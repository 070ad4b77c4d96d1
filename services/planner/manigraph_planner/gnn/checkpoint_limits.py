"""What reading a checkpoint may cost, checked before it is spent.

A checkpoint is a file anyone can hand the planner, so each check runs before the step whose
cost it bounds, the cheapest first (:func:`~.checkpoint.load_checkpoint` calls them in this
order):

1. :func:`check_archive`: the zip's central directory, read without inflating a byte: at
   most :data:`MAX_RECORDS` records, the pickle at most :data:`MAX_PICKLE_BYTES` and every
   record, and all of them together, at most :data:`MAX_ARCHIVE_BYTES` uncompressed. Before
   ``torch.load`` reads anything (a 1 MB file of one deflated record can inflate to 1 GB).
2. :func:`check_declared_sizes`: the sizes the model declares (:data:`DECLARED_LIMITS`)
   before any network is built (hidden channels 4096 and 64 layers would allocate gigabytes).
3. :func:`expected_state`: the parameters the declared network has, from a copy built on
   torch's ``meta`` device (shapes, no memory), compared with the stored tensors before the
   real network is allocated: what is built is then no bigger than what was stored.
4. :func:`check_finite`: every stored tensor finite, named when it is not.
5. :func:`check_vocabulary_order`: each categorical vocabulary, and the attributes, in the
   order training writes them (:meth:`~.task_features.TaskFeatures.learn`: sorted, ``id``
   last). A vocabulary reordered in both the names and the task stamp would otherwise feed
   each value into another value's column and load silently.

Each refusal is a one-line :class:`~manigraph_shared.errors.PolicyError` naming the field
and the limit; the planner exits with ``CONFIG_EXIT_CODE`` on it, so ``up`` does not restart
it. The limits are far above any checkpoint we train (the largest shipped: 69 records,
0.54 MB, 3 members x 3 layers x 64 channels, 17 columns) and listed in docs/training.md.
"""

from __future__ import annotations

import zipfile
from collections.abc import Mapping
from typing import IO, Any

import torch

from manigraph_planner.gnn.models import ModelConfig, PolicyNet
from manigraph_planner.gnn.models.build import policy_net_for
from manigraph_planner.gnn.task_features import TaskFeatures
from manigraph_shared.errors import PolicyError

__all__ = [
    "DECLARED_LIMITS",
    "MAX_ARCHIVE_BYTES",
    "MAX_PICKLE_BYTES",
    "MAX_RECORDS",
    "check_archive",
    "check_declared_sizes",
    "check_finite",
    "check_vocabulary_order",
    "expected_state",
]

#: Uncompressed bytes of one record, and of all records together (weights: 16 M floats).
MAX_ARCHIVE_BYTES = 64 * 2**20
#: Uncompressed bytes of the pickle (``data.pkl``): the plain-typed provenance and the
#: feature spec, which Python expands several times over in memory.
MAX_PICKLE_BYTES = 2**20
#: Records in the archive (one per tensor, plus a few).
MAX_RECORDS = 4096
#: The most each declared size may be (``model.<field>``; ``in_channels`` is also the
#: feature spec's column count, so it bounds a task's vocabularies).
DECLARED_LIMITS: Mapping[str, int] = {
    "hidden_channels": 1024,
    "num_layers": 16,
    "ensemble": 16,
    "in_channels": 1024,
}


def check_archive(stream: IO[bytes], path: object) -> None:
    """Refuse an archive whose records would inflate beyond the limits, from its central
    directory alone (``stream`` is left open, at an unspecified position)."""
    try:
        records = zipfile.ZipFile(stream).infolist()
    except (zipfile.BadZipFile, OSError, ValueError) as exc:
        raise PolicyError(f"not a manigraph checkpoint: {path}: a broken archive: {exc}") from None
    if len(records) > MAX_RECORDS:
        raise PolicyError(
            f"checkpoint archive: {len(records)} records, above the limit of {MAX_RECORDS}"
        )
    total = 0
    for record in records:
        limit = MAX_PICKLE_BYTES if record.filename.endswith("data.pkl") else MAX_ARCHIVE_BYTES
        if record.file_size > limit:
            raise PolicyError(
                f"checkpoint archive: record {record.filename!r} inflates to "
                f"{_size(record.file_size)}, above the limit of {_size(limit)}"
            )
        total += record.file_size
    if total > MAX_ARCHIVE_BYTES:
        raise PolicyError(
            f"checkpoint archive: its records inflate to {_size(total)} together, above the "
            f"limit of {_size(MAX_ARCHIVE_BYTES)}"
        )


def check_feature_columns(stored: Mapping[str, Any]) -> None:
    """Refuse a feature spec of more columns than a model may declare, before it is read."""
    names = stored.get("names")
    limit = DECLARED_LIMITS["in_channels"]
    if isinstance(names, list | tuple) and len(names) > limit:
        raise PolicyError(
            f"checkpoint feature_spec.names: {len(names)} columns, above the limit of {limit}"
        )


def check_declared_sizes(model: ModelConfig) -> None:
    """Refuse a model declaring a size above :data:`DECLARED_LIMITS`, naming the field."""
    for field, limit in DECLARED_LIMITS.items():
        value = getattr(model, field)
        if value > limit:
            raise PolicyError(
                f"checkpoint model.{field}: {value} is above the limit of {limit} "
                "a checkpoint may declare"
            )


def expected_state(model: ModelConfig) -> dict[str, torch.Tensor]:
    """The declared network's parameters as ``meta`` tensors: their names, shapes and dtypes,
    without memory (the weight holders have the PyG layers' names and shapes)."""
    with torch.device("meta"):
        net: PolicyNet = policy_net_for(model, message_passing=False)
    return dict(net.state_dict())


def check_finite(state: Mapping[str, Any]) -> None:
    """Refuse the first stored tensor holding NaN or an infinity, naming it."""
    for name, value in state.items():
        if not isinstance(value, torch.Tensor) or not (
            value.is_floating_point() or value.is_complex()
        ):
            continue
        bad = int((~torch.isfinite(value)).sum())
        if bad:
            raise PolicyError(
                f"checkpoint state_dict.{name}: {bad} of {value.numel()} values are NaN or infinite"
            )


def check_vocabulary_order(task: TaskFeatures) -> None:
    """Refuse attributes or vocabularies out of the order training writes them."""
    names = [a.name for a in task.attributes]
    ordered = sorted(n for n in names if n != "id") + (["id"] if "id" in names else [])
    if names != ordered:
        raise PolicyError(
            f"checkpoint feature_spec.task.attributes: in the order {names}, not {ordered} as "
            "training writes them (reordered columns would score the wrong ones)"
        )
    for attribute in task.attributes:
        words = list(attribute.vocabulary)
        if words != sorted(words):
            raise PolicyError(
                f"checkpoint feature_spec.task.attributes.{attribute.name}.vocabulary: in the "
                f"order {_short(words)}, not sorted as training writes it (a reordered "
                "vocabulary would feed each value into another's column)"
            )


def _short(words: list[str], shown: int = 6) -> str:
    more = f", ... {len(words) - shown} more" if len(words) > shown else ""
    return "[" + ", ".join(repr(w) for w in words[:shown]) + more + "]"


def _size(count: int) -> str:
    if count >= 2**30:
        return f"{count / 2**30:.1f} GiB"
    if count >= 2**20:
        return f"{count / 2**20:.1f} MiB"
    return f"{count / 2**10:.1f} KiB"
