"""What `manigraph up` and `run` name their episodes after and report in the summary."""

from __future__ import annotations

import os
from pathlib import Path

import pytest

from manigraph_shared.errors import ConfigError
from manigraph_shared.messages import EpisodeRequest
from manigraph_tools.episode_plan import (
    SEED_REFUSED,
    UNSET_BLOCKS,
    EpisodeOptions,
    EpisodeResult,
    read_task_file,
    summarize,
)


def test_a_dishwasher_run_is_named_and_summarised_by_its_dishes_not_blocks() -> None:
    options = EpisodeOptions(task="dishwasher", objects=10, preference="left-right")
    assert options.label() == "dishwasher-10"
    plan = options.plan(2, run_id=options.label())
    assert plan.request(1).episode_id == "dishwasher-10-0001"
    summary = summarize(plan, [])
    assert summary["objects"] == 10 and summary["preference"] == "left-right"
    assert "blocks" not in summary and "stacks" not in summary
    assert EpisodeOptions(task="dishwasher").label() == "dishwasher"  # the sim's default count
    assert EpisodeOptions(task="dishwasher").plan(1).describe() == "dishwasher"
    assert plan.describe() == "dishwasher 10 dishes left-right"  # progress lines: no K


def test_a_block_run_keeps_blocks_and_stacks() -> None:
    options = EpisodeOptions(task="multistack", blocks=3, stacks=3)
    summary = summarize(options.plan(1), [])
    assert options.label() == "multistack-3"
    assert summary["blocks"] == 3 and summary["stacks"] == 3 and "objects" not in summary
    assert options.plan(1).describe() == "multistack K=3"


def test_a_65_block_task_file_plans_requests_without_tripping_the_blocks_bound(
    tmp_path: Path,
) -> None:
    """The file's count names the run; the request's ``blocks`` (1-64) is not filled from it."""
    rows = [
        f'[[objects]]\nid = "b{i}"\ncategory = "block"\n'
        f"position = [{0.12 + 0.05 * (i % 15):.2f}, {-0.55 + 0.05 * (i // 15):.2f}, 0.02]\n"
        for i in range(65)
    ]
    path = tmp_path / "many.toml"
    path.write_text(
        "".join(rows) + '[[goals]]\nid = "g"\ncategory = "block"\nposition = [0.5, 0.3, 0.02]\n'
    )
    plan = EpisodeOptions(task_file=path).plan(1)
    assert plan.blocks == 65 and summarize(plan, [])["blocks"] == 65
    request = plan.request(0)
    assert request.task == "file" and request.blocks == UNSET_BLOCKS


@pytest.mark.parametrize("name", ["/dev/zero", "directory", "fifo"])
def test_what_is_not_a_regular_file_is_refused_by_name_without_reading_it(
    tmp_path: Path, name: str
) -> None:
    path = Path(name)
    if name == "directory":
        path = tmp_path
    elif name == "fifo":
        path = tmp_path / "pipe"
        os.mkfifo(path)  # reading it would block forever: nothing writes to it
    with pytest.raises(ConfigError, match="is not a regular file"):
        read_task_file(path)


def test_a_file_too_long_is_refused_having_read_at_most_the_limit(tmp_path: Path) -> None:
    limit = EpisodeRequest.max_length("task_file")
    path = tmp_path / "long.toml"
    path.write_text("#" * (limit + 1))
    with pytest.raises(ConfigError, match=f"has {limit + 1:,} characters"):
        read_task_file(path)
    path.write_bytes(b"#" * (4 * limit + 10))
    with pytest.raises(ConfigError, match="has over"):
        read_task_file(path)


def test_control_characters_in_a_path_are_escaped_in_the_refusal(tmp_path: Path) -> None:
    path = tmp_path / "evil\x1b[2J.toml"
    with pytest.raises(ConfigError) as refused:
        read_task_file(path)
    assert "\x1b" not in str(refused.value) and "\\x1b[2J" in str(refused.value)


def test_rules_ride_in_each_request_and_the_summary_counts_violations_and_refusals(
    tmp_path: Path,
) -> None:
    task, rules = tmp_path / "t.toml", tmp_path / "r.toml"
    task.write_text("# a layout\n")
    rules.write_text('same = ["colour"]\n')
    plan = EpisodeOptions(task_file=task, rules=rules).plan(2)
    assert plan.request(1).rules == 'same = ["colour"]\n' and plan.request(1).task_file
    done = EpisodeResult("e0", 0, True, 2, 2, 4, 0.1, "all goals filled", rule_violations=1)
    refused = EpisodeResult("e1", 1, False, 0, 0, 0, 0.1, f"{SEED_REFUSED}: t, seed 1: why")
    summary = summarize(plan, [done, refused])
    assert summary["rule_violations"] == 1
    assert summary["refused_seeds"] == [{"seed": 1, "reason": "t, seed 1: why"}]
    assert "rule_violations" not in summarize(EpisodeOptions(task_file=task).plan(1), [done])
    with pytest.raises(ConfigError, match=r"^rules: .*give --task-file too"):
        EpisodeOptions(rules=rules).plan(1)
