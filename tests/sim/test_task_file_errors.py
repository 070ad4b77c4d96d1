"""A task file's mistakes in one clear line: a misspelt key names its line and the field it
meant; a file nested thousands deep is refused, not a 3,000-line traceback (issue 45)."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

from manigraph_blocks.sim.task_file import parse_task_file
from manigraph_shared.errors import TaskError
from manigraph_shared.messages import EpisodeRequest
from manigraph_sim.geometric.backend import GeometricBackend

VALID = """name = "one block"

[[objects]]
id = "a"
category = "block"
position = [0.5, 0.0, 0.02]

[[objects]]
id = "b"
category = "block"
position = [0.5, 0.2, 0.02]

[[goals]]
id = "g"
category = "block"
position = [0.4, 0.2, 0.02]
"""

DEEP_ARRAYS = "x = " + "[" * 10_000 + "]" * 10_000 + "\n"
DEEP_TABLES = "x = " + "{a=" * 5_000 + "1" + "}" * 5_000 + "\n"


@pytest.mark.parametrize(
    ("typo", "expected"),
    [
        (
            ("position = [0.5, 0.2", "postion = [0.5, 0.2"),
            "line 11: objects.1.postion: is no key of this table; did you mean position?",
        ),
        (("name =", "nmae ="), "line 1: nmae: is no key of this table; did you mean name?"),
        (
            (
                'category = "block"\nposition = [0.4',
                'category = "block"\noptinal = true\nposition = [0.4',
            ),
            "line 16: goals.0.optinal: is no key of this table; did you mean optional?",
        ),
        (
            (
                "position = [0.5, 0.0, 0.02]",
                "position = [0.5, 0.0, 0.02]\nattributes = { colour = true }",
            ),
            "line 7: objects.0.attributes.colour",
        ),
    ],
    ids=["object key", "top-level key", "goal key", "a value inside an inline table"],
)
def test_a_misspelt_key_names_its_line_and_the_field_it_meant(
    typo: tuple[str, str], expected: str
) -> None:
    with pytest.raises(TaskError) as caught:
        parse_task_file(VALID.replace(*typo), "layout.toml")
    message = str(caught.value)
    assert message.startswith("task file layout.toml: ") and expected in message
    assert "\n" not in message


def test_a_key_nothing_resembles_suggests_nothing() -> None:
    with pytest.raises(TaskError) as caught:
        parse_task_file(VALID.replace("name =", "zzz ="))
    assert str(caught.value) == "task file: line 1: zzz: is no key of this table"


@pytest.mark.parametrize("text", [DEEP_ARRAYS, DEEP_TABLES], ids=["arrays", "inline tables"])
def test_a_deeply_nested_file_is_refused_in_one_line_naming_the_file(text: str) -> None:
    with pytest.raises(TaskError) as caught:
        parse_task_file(text, "deep.toml")
    assert str(caught.value) == (
        "task file deep.toml: arrays or tables nested too deeply to read "
        "(a task file needs a few levels)"
    )


@pytest.mark.parametrize("text", [DEEP_ARRAYS, DEEP_TABLES], ids=["arrays", "inline tables"])
def test_the_sim_refuses_a_deeply_nested_file_at_reset_by_name(text: str) -> None:
    request = EpisodeRequest(episode_id="f", task="file", task_file=text)
    with pytest.raises(TaskError, match=r"^task file: arrays or tables nested too deeply"):
        GeometricBackend().reset(request, 0.0)


def test_the_eval_command_refuses_a_deeply_nested_file_in_one_line_naming_it(
    tmp_path: Path,
) -> None:
    deep = tmp_path / "deep.toml"
    deep.write_text(DEEP_ARRAYS)
    result = subprocess.run(
        [sys.executable, "-m", "manigraph_shared.cli", "eval", "--task-file", str(deep)],
        capture_output=True,
        text=True,
        timeout=120,
        check=False,
    )
    lines = result.stderr.strip().splitlines()
    assert result.returncode != 0 and len(lines) == 1, result.stderr[-2000:]
    assert f"task file {deep}: arrays or tables nested too deeply" in lines[0]
