from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import Any

import pytest
import torch

from manigraph_planner.gnn.checkpoint import load_checkpoint, save_checkpoint
from manigraph_planner.gnn.features import graph_from_arrays
from manigraph_planner.gnn.models import ARCHITECTURES, ModelConfig, PolicyNet
from manigraph_shared.errors import PolicyError

TRAINING = {"lr": 0.001, "epochs": 3, "tasks": ["stack-3", "stack-4"], "seed": None}


def saved(tmp_path: Path, arch: str = "sage") -> tuple[Path, PolicyNet]:
    torch.manual_seed(0)
    net = PolicyNet(ModelConfig(arch, feature_scale=(1, 10, 10, 10, 1)))
    path = save_checkpoint(
        tmp_path / f"{arch}.pt",
        net,
        training_config=TRAINING,
        data_hash="sha256:abc",
        metrics={"val_accuracy": 0.9},
    )
    return path, net


def rewrite(path: Path, change: Callable[[dict[str, Any]], None]) -> Path:
    payload = torch.load(path, weights_only=True)
    change(payload)
    torch.save(payload, path)
    return path


def recode_blocks(payload: dict[str, Any]) -> None:
    payload["feature_spec"]["category_codes"]["block"] = 5


@pytest.mark.parametrize("arch", sorted(ARCHITECTURES))
def test_round_trip_gives_identical_logits_and_provenance(tmp_path: Path, arch: str) -> None:
    path, net = saved(tmp_path, arch)
    loaded, info = load_checkpoint(path)
    graph = graph_from_arrays([1, 0, 1, 2, 3], torch.rand(5, 3), [0, 1, 0, 1, 0])
    with torch.no_grad():
        assert torch.equal(loaded(graph.x, graph.edge_index), net.eval()(graph.x, graph.edge_index))
    assert not loaded.training
    assert info.architecture == arch and info.model == net.config
    assert info.training_config == TRAINING
    assert info.data_hash == "sha256:abc" and info.metrics == {"val_accuracy": 0.9}
    assert info.feature_spec["names"] == ["category", "x", "y", "z", "filled"]
    assert info.manigraph_version


@pytest.mark.parametrize(
    ("change", "field"),
    [
        (lambda p: p["feature_spec"].update(names=["category", "x", "y"]), "feature_spec.names"),
        (recode_blocks, "feature_spec.category_codes"),
        (lambda p: p["feature_spec"].update(version="0"), "feature_spec.version"),
        (lambda p: p["model"].update(architecture="transformer"), "model.architecture"),
        (lambda p: p["model"].update(num_layers=0), "model.num_layers"),
        (lambda p: p["model"].update(hidden_channels=32), "state_dict"),
        (lambda p: p.update(format_version=2), "format_version"),
        (lambda p: p.pop("data_hash"), "data_hash"),
        (lambda p: p.update(optimizer={}), "optimizer"),
        (lambda p: p.update(metrics=[1, 2]), "metrics"),
    ],
)
def test_refuses_checkpoints_it_cannot_trust_naming_the_field(
    tmp_path: Path, change: Callable[[dict[str, Any]], None], field: str
) -> None:
    path = rewrite(saved(tmp_path)[0], change)
    with pytest.raises(PolicyError, match=rf"^checkpoint {field}:"):
        load_checkpoint(path)


def test_feature_spec_mismatch_says_what_each_side_has(tmp_path: Path) -> None:
    path = rewrite(saved(tmp_path)[0], lambda p: p["feature_spec"].update(names=["a", "b"]))
    with pytest.raises(PolicyError) as caught:
        load_checkpoint(path)
    assert "file has ('a', 'b')" in str(caught.value)
    assert "expects ('category', 'x', 'y', 'z', 'filled')" in str(caught.value)


@pytest.mark.parametrize(
    "make_file",
    [
        lambda path: path.write_bytes(bytes(range(256)) * 8),  # garbage
        lambda path: path.write_bytes(saved(path.parent)[0].read_bytes()[:3000]),  # truncated
        lambda path: path.write_bytes(b""),  # empty
        lambda path: torch.save(Path("not/a/checkpoint"), path),  # pickled code, not weights
        lambda path: torch.save([1, 2, 3], path),  # not a dict
        lambda path: torch.save({"weights": torch.zeros(3)}, path),  # wrong keys
        lambda path: rewrite(saved(path.parent)[0], lambda p: p.update(format="other")).rename(
            path
        ),
        lambda path: path.write_text("e\n"),  # torch.load: KeyError: 101
        lambda path: path.write_text("# manigraph\n\nA README.\n"),
    ],
    ids=[
        "garbage",
        "truncated",
        "empty",
        "pickled-object",
        "list",
        "wrong-keys",
        "other-format",
        "one-letter",
        "text",
    ],
)
def test_refuses_files_that_are_not_manigraph_checkpoints(
    tmp_path: Path, make_file: Callable[[Path], object]
) -> None:
    path = tmp_path / "bad.pt"
    make_file(path)
    with pytest.raises(PolicyError, match=rf"^not a manigraph checkpoint: {path}: \w") as caught:
        load_checkpoint(path)
    assert "\n" not in str(caught.value) and "KeyError" not in str(caught.value)


def test_a_text_file_is_named_as_one(tmp_path: Path) -> None:
    path = tmp_path / "notes.pt"
    path.write_text("e\n")
    with pytest.raises(PolicyError, match=r"a text file, not an archive torch\.save writes$"):
        load_checkpoint(path)


def test_missing_file_is_a_policy_error(tmp_path: Path) -> None:
    with pytest.raises(PolicyError, match="no such file"):
        load_checkpoint(tmp_path / "absent.pt")


@pytest.mark.parametrize(
    ("kwargs", "field"),
    [
        ({"training_config": {"out": Path("x")}}, "training_config.out"),
        ({"training_config": {}, "metrics": {"curve": [torch.zeros(1)]}}, r"metrics.curve\[0\]"),
        ({"training_config": {}, "data_hash": ""}, "data_hash"),
    ],
)
def test_save_accepts_only_plain_provenance(
    tmp_path: Path, kwargs: dict[str, Any], field: str
) -> None:
    kwargs.setdefault("data_hash", "h")
    with pytest.raises(ValueError, match=rf"^{field}:"):
        save_checkpoint(tmp_path / "x.pt", PolicyNet(ModelConfig("gcn")), **kwargs)
    assert not (tmp_path / "x.pt").exists()
