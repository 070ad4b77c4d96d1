"""What `manigraph up` and `run` name their episodes after and report in the summary."""

from __future__ import annotations

from manigraph_tools.episode_plan import EpisodeOptions, summarize


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
