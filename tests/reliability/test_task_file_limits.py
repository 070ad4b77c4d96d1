"""A task file the contract cannot carry is refused by the client, naming the limit."""

from __future__ import annotations

import time
from pathlib import Path

import pytest

from manigraph_blocks.sim.task_file import parse_task_file
from manigraph_shared.errors import ConfigError, TaskError
from manigraph_tools.episode_plan import read_task_file


def test_an_oversized_task_file_is_refused_before_anything_is_sent(tmp_path: Path) -> None:
    big = tmp_path / "big.toml"
    big.write_text("# padding\n" * 7000)  # 70,000 characters
    with pytest.raises(ConfigError, match="70,000 characters; a task file holds at most 65,536"):
        read_task_file(big)


def test_a_task_file_that_is_not_text_is_refused(tmp_path: Path) -> None:
    binary = tmp_path / "layout.toml"
    binary.write_bytes(b"\xff\xfe\x00 not utf-8")
    with pytest.raises(ConfigError, match="not UTF-8 text"):
        read_task_file(binary)


def test_a_task_file_within_the_limit_is_read_as_is(tmp_path: Path) -> None:
    small = tmp_path / "ok.toml"
    small.write_text('name = "x"\n')
    assert read_task_file(small) == 'name = "x"\n'


def _objects(count: int, positions: int) -> str:
    """``count`` blocks, each with ``positions`` listed positions that collide with the
    next block's, and one goal."""
    lines = []
    for i in range(count):
        listed = ", ".join(
            f"[{0.2 + 0.01 * (k % 60):.2f}, {-0.3 + 0.01 * i:.2f}, 0.02]" for k in range(positions)
        )
        lines += ["[[objects]]", f'id = "b{i}"', 'category = "block"', f"positions = [{listed}]"]
    lines += ["[[goals]]", 'id = "g"', 'category = "block"', "position = [0.4, 0.2, 0.02]"]
    return "\n".join(lines)


def _overlapping(count: int) -> str:
    lines = []
    for i in range(count):
        lines += ["[[objects]]", f'id = "b{i}"', 'category = "block"', "position = [0.5, 0, 0.02]"]
    lines += ["[[goals]]", 'id = "g"', 'category = "block"', "position = [0.4, 0.2, 0.02]"]
    return "\n".join(lines)


@pytest.mark.parametrize(
    "text",
    [_overlapping(256), _objects(40, 64)],
    ids=["256 blocks in one place", "40 blocks x 64 listed positions"],
)
def test_the_worst_task_file_that_fits_is_refused_in_well_under_a_second_of_cpu(
    text: str,
) -> None:
    """The sim validates a reset's task file on its service thread: before, the first took
    seconds of CPU (towers looked up per pair of objects) and the second 13 s (placements
    compared one pair at a time), so one reset stalled the sim past doctor and the next
    reset on a loaded machine."""
    assert len(text) <= 65_536  # what a reset request can carry
    started = time.process_time()
    with pytest.raises(TaskError, match="overlaps"):
        parse_task_file(text)
    assert time.process_time() - started < 2.0
