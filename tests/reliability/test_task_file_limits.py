"""A task file the contract cannot carry is refused by the client, naming the limit."""

from __future__ import annotations

from pathlib import Path

import pytest

from manigraph_shared.errors import ConfigError
from manigraph_tools.episodes import read_task_file


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
