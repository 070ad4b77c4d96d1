"""Hostile checkpoints (issue 48 item 6): each refused in one line naming the field and the
limit, before it costs what it declares; the shipped checkpoints load unchanged."""

from __future__ import annotations

import zipfile
from collections.abc import Callable
from pathlib import Path
from typing import Any

import pytest
import torch

from manigraph_planner.gnn import checkpoint as checkpoint_module
from manigraph_planner.gnn import checkpoint_limits as limits
from manigraph_planner.gnn.checkpoint import load_checkpoint, save_checkpoint
from manigraph_planner.gnn.features import FeatureSpec
from manigraph_planner.gnn.models import ModelConfig, PolicyNet
from manigraph_planner.gnn.task_features import TaskFeatures
from manigraph_shared.cli import main
from manigraph_shared.errors import CONFIG_EXIT_CODE, PolicyError
from manigraph_shared.messages import Scene, SceneGoal, SceneObject, Vector3

REPO = Path(__file__).resolve().parents[3]
SHIPPED = sorted((REPO / "checkpoints").glob("*.pt"))
SAGE = REPO / "checkpoints" / "sage.pt"
DISHWASHER = REPO / "checkpoints" / "dishwasher-left-right-sage.pt"


def rewritten(source: Path, target: Path, change: Callable[[dict[str, Any]], None]) -> Path:
    payload = torch.load(source, weights_only=True)
    change(payload)
    torch.save(payload, target)
    return target


def refusal(path: Path) -> str:
    with pytest.raises(PolicyError) as caught:
        load_checkpoint(path, message_passing=False)
    message = str(caught.value)
    assert "\n" not in message and len(message) < 400, message
    return message


@pytest.fixture
def never_built(monkeypatch: pytest.MonkeyPatch) -> None:
    """Fail the test if the real network is built: the refusal must come before."""

    def refuse(*_args: object, **_kwargs: object) -> None:
        raise AssertionError("the network was built before the checkpoint was refused")

    monkeypatch.setattr(checkpoint_module, "policy_net_for", refuse)


@pytest.mark.parametrize("path", SHIPPED, ids=lambda p: p.name)
def test_every_shipped_checkpoint_still_loads(path: Path) -> None:
    net, info = load_checkpoint(path, message_passing=False)
    assert info.model.hidden_channels == 64 and not net.training


@pytest.mark.parametrize(
    ("source", "declared", "field", "limit"),
    [
        (SAGE, {"hidden_channels": 4096, "num_layers": 64}, "hidden_channels", 1024),
        (SAGE, {"num_layers": 64}, "num_layers", 16),
        (DISHWASHER, {"ensemble": 4096}, "ensemble", 16),
    ],
    ids=["hidden-4096-layers-64", "layers-64", "ensemble-4096"],
)
@pytest.mark.usefixtures("never_built")
def test_declared_sizes_above_the_limits_are_refused_naming_field_and_limit(
    tmp_path: Path, source: Path, declared: dict[str, int], field: str, limit: int
) -> None:
    path = rewritten(source, tmp_path / "big.pt", lambda p: p["model"].update(declared))
    message = refusal(path)
    assert message.startswith(f"checkpoint model.{field}: ")
    assert f"above the limit of {limit}" in message


@pytest.mark.usefixtures("never_built")
def test_declared_sizes_within_the_limits_but_beyond_the_weights_are_refused_before_building(
    tmp_path: Path,
) -> None:
    declared = {"hidden_channels": 1024, "num_layers": 16}  # 34 M parameters, 80 KB stored
    path = rewritten(SAGE, tmp_path / "big.pt", lambda p: p["model"].update(declared))
    message = refusal(path)
    assert message.startswith("checkpoint state_dict: does not fit architecture 'sage'")
    assert "hidden_channels=1024, num_layers=16" in message


def test_a_task_spec_of_more_columns_than_the_limit_is_refused(tmp_path: Path) -> None:
    words = [f"w{index:05d}" for index in range(2000)]
    path = task_checkpoint(tmp_path)

    def widen(payload: dict[str, Any]) -> None:
        payload["feature_spec"]["task"]["attributes"][0]["vocabulary"] = words
        payload["feature_spec"]["names"] += words

    rewritten(path, path, widen)
    message = refusal(path)
    assert message.startswith("checkpoint feature_spec.names: ")
    assert "above the limit of 1024" in message


def deflated_copy(source: Path, target: Path, extra: tuple[str, int] | None = None) -> Path:
    """``source`` with every record deflated, plus ``extra``: (name, bytes of zeros)."""
    with zipfile.ZipFile(source) as src, zipfile.ZipFile(target, "w") as dst:
        prefix = src.namelist()[0].split("/")[0]
        for info in src.infolist():
            dst.writestr(info.filename, src.read(info), compress_type=zipfile.ZIP_DEFLATED)
        if extra is not None:
            name, size = extra
            record = zipfile.ZipInfo(f"{prefix}/{name}")
            record.compress_type = zipfile.ZIP_DEFLATED
            with dst.open(record, "w", force_zip64=True) as stream:
                chunk = bytes(2**20)
                for _ in range(size // len(chunk)):
                    stream.write(chunk)
                stream.write(bytes(size % len(chunk)))
    return target


def test_a_deflated_archive_within_the_limits_loads(tmp_path: Path) -> None:
    load_checkpoint(deflated_copy(SAGE, tmp_path / "deflated.pt"), message_passing=False)


def test_a_record_inflating_beyond_the_limit_is_refused_before_torch_reads_it(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    size = limits.MAX_ARCHIVE_BYTES + 2**20  # 65 MiB of zeros: a 65 KB file
    path = deflated_copy(SAGE, tmp_path / "bomb.pt", ("data/99", size))
    assert path.stat().st_size < 2**20

    def never(*_args: object, **_kwargs: object) -> None:
        raise AssertionError("torch.load read an archive beyond the limits")

    monkeypatch.setattr(checkpoint_module.torch, "load", never)
    message = refusal(path)
    assert message.startswith("checkpoint archive: record ")
    assert "data/99' inflates to 65.0 MiB, above the limit of 64.0 MiB" in message


def test_records_that_inflate_beyond_the_limit_together_are_refused(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setattr(limits, "MAX_ARCHIVE_BYTES", 100_000)  # sage.pt holds 72 KB
    path = deflated_copy(SAGE, tmp_path / "two.pt", ("data/99", 60_000))
    assert "inflate to 129.5 KiB together, above the limit of 97.7 KiB" in refusal(path)


def test_a_pickle_beyond_its_limit_is_refused(tmp_path: Path) -> None:
    path = rewritten(
        SAGE, tmp_path / "long.pt", lambda p: p["training_config"].update(notes="x" * 2**21)
    )
    message = refusal(path)
    assert message.startswith("checkpoint archive: record ")
    assert "data.pkl' inflates to 2.0 MiB, above the limit of 1.0 MiB" in message


def test_too_many_records_are_refused(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(limits, "MAX_RECORDS", 20)  # sage.pt has 17
    path = deflated_copy(SAGE, tmp_path / "many.pt")
    with zipfile.ZipFile(path, "a") as archive:
        for index in range(5):
            archive.writestr(f"sage/extra/{index}", b"")
    assert refusal(path) == "checkpoint archive: 22 records, above the limit of 20"


@pytest.mark.parametrize("value", [float("nan"), float("inf"), float("-inf")])
@pytest.mark.usefixtures("never_built")
def test_weights_that_are_not_finite_are_refused_naming_the_tensor(
    tmp_path: Path, value: float
) -> None:
    def poison(payload: dict[str, Any]) -> None:
        payload["state_dict"]["backbone.convs.1.lin_l.weight"][3, 7] = value

    path = rewritten(SAGE, tmp_path / "nan.pt", poison)
    assert refusal(path) == (
        "checkpoint state_dict.backbone.convs.1.lin_l.weight: 1 of 4096 values are NaN or infinite"
    )


@pytest.mark.filterwarnings("ignore:Validating sparse tensor invariants")
def test_a_sparse_weight_is_refused_as_a_misfit(tmp_path: Path) -> None:
    def sparsify(payload: dict[str, Any]) -> None:
        weights = payload["state_dict"]
        weights["head.weight"] = weights["head.weight"].to_sparse()

    path = rewritten(SAGE, tmp_path / "sparse.pt", sparsify)
    assert "head.weight is a torch.sparse_coo tensor, expected a dense one" in refusal(path)


def block(name: str, x: float, colour: str) -> SceneObject:
    return SceneObject(
        id=name,
        category="block",
        position=Vector3(x=x, y=-0.2, z=0.02),
        size=Vector3(x=0.04, y=0.04, z=0.04),
        attributes={"colour": colour, "shade": colour},
    )


def task_checkpoint(tmp_path: Path) -> Path:
    """A policy trained on colours (vocabulary blue, green, red) and shades: two attributes."""
    slot = SceneGoal(
        id="red_slot", category="block", position=Vector3(x=0.4, y=0.2, z=0.02), accepts={}
    )
    scene = Scene(
        episode_id="t",
        stamp=1.0,
        sequence=0,
        objects=[block("b0", 0.4, "red"), block("b1", 0.5, "blue"), block("b2", 0.6, "green")],
        goals=[slot],
    )
    spec = FeatureSpec.for_task(TaskFeatures.learn([scene]))
    net = PolicyNet(ModelConfig("sage", features=spec))
    return save_checkpoint(tmp_path / "task.pt", net, training_config={}, data_hash="h")


def reorder_vocabulary(payload: dict[str, Any]) -> None:
    """Consistently: the stamp's vocabulary and the column names, as a forger would."""
    colour = payload["feature_spec"]["task"]["attributes"][0]
    assert colour == {"name": "colour", "vocabulary": ["blue", "green", "red"]}
    colour["vocabulary"] = ["red", "green", "blue"]
    names = payload["feature_spec"]["names"]
    first = names.index("colour=blue")
    names[first : first + 3] = ["colour=red", "colour=green", "colour=blue"]


def reorder_attributes(payload: dict[str, Any]) -> None:
    task = payload["feature_spec"]["task"]
    task["attributes"].reverse()
    spec = FeatureSpec.for_task(TaskFeatures.from_dict(task))
    payload["feature_spec"]["names"] = list(spec.names)


def test_a_task_checkpoint_as_saved_loads(tmp_path: Path) -> None:
    net, _ = load_checkpoint(task_checkpoint(tmp_path), message_passing=False)
    assert net.config.feature_spec.task is not None


@pytest.mark.parametrize(
    ("change", "expected"),
    [
        (
            reorder_vocabulary,
            "checkpoint feature_spec.task.attributes.colour.vocabulary: in the order "
            "['red', 'green', 'blue'], not sorted as training writes it",
        ),
        (
            reorder_attributes,
            "checkpoint feature_spec.task.attributes: in the order ['shade', 'colour'], "
            "not ['colour', 'shade'] as training writes them",
        ),
    ],
    ids=["vocabulary", "attributes"],
)
@pytest.mark.usefixtures("never_built")
def test_a_consistently_reordered_vocabulary_is_refused(
    tmp_path: Path, change: Callable[[dict[str, Any]], None], expected: str
) -> None:
    path = task_checkpoint(tmp_path)
    rewritten(path, path, change)
    assert refusal(path).startswith(expected)


def test_the_planner_exits_with_the_configuration_code_on_a_hostile_checkpoint(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """``up``'s supervisor does not restart a service that exits with CONFIG_EXIT_CODE."""
    path = rewritten(
        SAGE, tmp_path / "big.pt", lambda p: p["model"].update(hidden_channels=4096, num_layers=64)
    )
    code = main(["planner", "--policy", str(path)])
    lines = capsys.readouterr().err.strip().splitlines()
    assert code == CONFIG_EXIT_CODE
    assert (
        len(lines) == 1
        and "checkpoint model.hidden_channels: 4096 is above the limit" in (lines[0])
    ), lines
