"""What `manigraph export` does with input it cannot take whole: a truncated log is exported
as far as it goes and says where it stopped; a missing file, a file that is not MCAP and an
output folder that already holds something are refused in one line, before anything is
written."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest
from rosbags.rosbag2 import Reader

from manigraph_shared.errors import CONFIG_EXIT_CODE
from manigraph_shared.mcap_log import read_log
from manigraph_shared.messages import JointState


def export(log: Path, out: Path, fmt: str = "ros2") -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [
            sys.executable,
            "-m",
            "manigraph_shared.cli",
            "export",
            str(log),
            "--format",
            fmt,
            "-o",
            str(out),
        ],
        capture_output=True,
        text=True,
        timeout=120,
        check=False,
    )


def bag_counts(bag: Path) -> dict[str, int]:
    with Reader(bag) as reader:
        return {c.topic: c.msgcount for c in reader.connections}


def test_a_truncated_log_exports_what_it_can_and_says_where_it_stopped(
    robot_log: Path, tmp_path: Path
) -> None:
    cut = tmp_path / "cut.mcap"
    data = robot_log.read_bytes()
    cut.write_bytes(data[: len(data) * 4 // 10])  # a recorder killed mid-write
    kept = list(read_log(cut))
    assert 0 < len(kept) < len(list(read_log(robot_log)))

    result = export(cut, tmp_path / "bag")

    assert result.returncode == 0, result.stderr
    assert "Traceback" not in result.stderr
    summary = json.loads(result.stdout.strip().splitlines()[-1])
    assert summary["truncated"]["messages_read"] == len(kept)
    assert summary["truncated"]["last_log_time_ns"] == kept[-1].log_time_ns
    joint_states = sum(1 for item in kept if item.topic == JointState.key)
    assert joint_states > 0
    assert bag_counts(tmp_path / "bag")["/manigraph/joint_states"] == joint_states


def test_a_finalised_log_is_not_called_truncated(robot_log: Path, tmp_path: Path) -> None:
    result = export(robot_log, tmp_path / "bag")
    assert result.returncode == 0, result.stderr
    assert json.loads(result.stdout.strip().splitlines()[-1])["truncated"] is None


def test_an_existing_empty_folder_is_written_into(robot_log: Path, tmp_path: Path) -> None:
    (tmp_path / "bag").mkdir()
    result = export(robot_log, tmp_path / "bag")
    assert result.returncode == 0, result.stderr
    assert (tmp_path / "bag" / "metadata.yaml").exists()


@pytest.mark.parametrize(
    ("make", "problem"),
    [
        (lambda d: d / "missing.mcap", "missing.mcap does not exist"),
        (lambda d: _write(d / "notes.mcap", b"just some text\n" * 10), "is not an MCAP file"),
        (lambda d: _write(d / "empty.mcap", b""), "is not an MCAP file"),
        (lambda d: d, "is not a file"),
    ],
    ids=["missing", "not-mcap", "empty", "a-folder"],
)
def test_bad_input_is_refused_in_one_line(tmp_path: Path, make, problem: str) -> None:  # type: ignore[no-untyped-def]
    out = tmp_path / "out"
    result = export(make(tmp_path), out)
    assert result.returncode == CONFIG_EXIT_CODE
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("manigraph export: log: "), result.stderr
    assert problem in lines[0]
    assert not out.exists()


def test_an_output_folder_holding_something_is_refused(robot_log: Path, tmp_path: Path) -> None:
    out = tmp_path / "out"
    out.mkdir()
    (out / "keep.txt").write_text("mine")
    result = export(robot_log, out)
    assert result.returncode == CONFIG_EXIT_CODE
    assert result.stderr.strip() == (
        f"manigraph export: output: {out} exists and is not empty (give a new or empty folder)"
    )
    assert [p.name for p in out.iterdir()] == ["keep.txt"]


def test_an_unknown_format_is_refused_naming_the_formats(robot_log: Path, tmp_path: Path) -> None:
    result = export(robot_log, tmp_path / "out", fmt="rosbag1")
    assert result.returncode != 0
    assert "invalid choice: 'rosbag1'" in result.stderr and "ros2" in result.stderr


def _write(path: Path, data: bytes) -> Path:
    path.write_bytes(data)
    return path


# An install without the `lerobot` extra (a service image): pyarrow cannot be imported.
WITHOUT_PYARROW = """
import sys
sys.modules["pyarrow"] = None  # what an install without it gives: ImportError
from manigraph_shared.cli import main
sys.exit(main(sys.argv[1:]))
"""


def test_a_lerobot_export_without_pyarrow_says_what_to_install(
    robot_log: Path, tmp_path: Path
) -> None:
    out = tmp_path / "out"
    argv = ["export", str(robot_log), "--format", "lerobot", "-o", str(out)]
    result = subprocess.run(
        [sys.executable, "-c", WITHOUT_PYARROW, *argv],
        capture_output=True,
        text=True,
        timeout=120,
        check=False,
    )
    assert result.returncode == CONFIG_EXIT_CODE, result.stderr
    assert result.stderr.strip().splitlines() == [
        "manigraph export: format: a LeRobot export needs pyarrow, which this install lacks "
        "(pip install 'manigraph-tools[lerobot]')"
    ]
    assert not out.exists()
