"""`manigraph export` of a log recorded from robot cells: ``manigraph record`` in the default
cell writes every cell on its own channels (``manigraph/left/world/scene``), ``record --cell
left`` that cell's only. A log of one cell exports as it is; a log of several exports the
cell chosen with ``--cell`` and refuses, naming the cells it holds, when none is."""

from __future__ import annotations

import io
import json
import subprocess
import sys
from pathlib import Path

import pytest
from rosbags.rosbag2 import Reader

from manigraph_shared.cells import cell_key
from manigraph_shared.errors import CONFIG_EXIT_CODE, ConfigError
from manigraph_shared.mcap_log import McapLogWriter, read_log
from manigraph_shared.messages import ServiceState, ServiceStatus
from manigraph_tools.interop.lerobot_export import export_lerobot
from manigraph_tools.interop.source import cells_in


def recorded_from(source: Path, out: Path, cells: list[str | None], heartbeat: bool) -> Path:
    """``source``'s messages as a recorder of ``cells`` wrote them: each in every cell, on
    that cell's key; with ``heartbeat``, the recorder's own heartbeat in the default cell
    (as a recorder of every cell sends it)."""
    writer = McapLogWriter(out)
    for item in read_log(source):
        for cell in cells:
            writer.write(cell_key(item.topic, cell), item.data, item.log_time_ns)
    if heartbeat:
        status = ServiceStatus(service="recorder", state=ServiceState.OK, detail="", stamp=1.0)
        writer.write(status.key_for(), status.encode(), 1)
    writer.close()
    return out


def export(
    log: Path, out: Path, *extra: str, fmt: str = "ros2"
) -> subprocess.CompletedProcess[str]:
    argv = [sys.executable, "-m", "manigraph_shared.cli", "export", str(log), "--format", fmt]
    return subprocess.run(
        [*argv, "-o", str(out), *extra], capture_output=True, text=True, timeout=120, check=False
    )


def bag_counts(bag: Path) -> dict[str, int]:
    with Reader(bag) as reader:
        return {c.topic: c.msgcount for c in reader.connections}


@pytest.fixture(scope="module")
def two_cells(robot_log: Path, tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp("cells") / "two-cells.mcap"
    return recorded_from(robot_log, out, ["left", "right"], heartbeat=True)


def test_a_log_of_several_cells_is_refused_naming_them_when_none_is_chosen(
    two_cells: Path, tmp_path: Path
) -> None:
    assert cells_in(two_cells) == ["left", "right"]  # the recorder's heartbeat is no cell
    result = export(two_cells, tmp_path / "bag")
    assert result.returncode == CONFIG_EXIT_CODE
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("manigraph export: cell: "), result.stderr
    assert "holds several robot cells (left, right): choose one with --cell NAME" in lines[0]
    assert not (tmp_path / "bag").exists()


def test_the_chosen_cell_exports_as_a_log_of_that_cell_alone(
    robot_log: Path, two_cells: Path, tmp_path: Path
) -> None:
    plain = export(robot_log, tmp_path / "plain")
    assert plain.returncode == 0, plain.stderr
    result = export(two_cells, tmp_path / "left", "--cell", "left")
    assert result.returncode == 0, result.stderr
    summary = json.loads(result.stdout.strip().splitlines()[-1])
    assert summary["cell"] == "left"
    assert bag_counts(tmp_path / "left") == bag_counts(tmp_path / "plain")
    assert all(topic.startswith("manigraph/left/") for topic in summary["read"])
    assert summary["invalid"] == {}


def test_a_cell_the_log_does_not_hold_is_refused_naming_those_it_holds(
    two_cells: Path, tmp_path: Path
) -> None:
    result = export(two_cells, tmp_path / "bag", "--cell", "middle")
    assert result.returncode == CONFIG_EXIT_CODE
    assert "holds no middle (cells present: left, right)" in result.stderr
    assert not (tmp_path / "bag").exists()


def test_a_log_recorded_in_one_cell_exports_without_naming_it(
    robot_log: Path, tmp_path: Path
) -> None:
    """``record --cell left``: every key in cell left, the recorder's heartbeat too."""
    log = recorded_from(robot_log, tmp_path / "left.mcap", ["left"], heartbeat=False)
    plain = export_lerobot(robot_log, tmp_path / "plain", io.StringIO())
    summary = export_lerobot(log, tmp_path / "left", io.StringIO())
    assert summary["cell"] == "left" and plain["cell"] is None
    assert (summary["episodes"], summary["frames"]) == (plain["episodes"], plain["frames"])
    assert summary["frames"] > 0
    with pytest.raises(ConfigError, match="several robot cells"):
        both = recorded_from(robot_log, tmp_path / "both.mcap", [None, "left"], heartbeat=False)
        export_lerobot(both, tmp_path / "both", io.StringIO())
    assert export_lerobot(both, tmp_path / "default", io.StringIO(), "")["cell"] is None
