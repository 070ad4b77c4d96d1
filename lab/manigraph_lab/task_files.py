"""A task file and its rules file read and checked before any episode, as ``demos``, ``eval``,
``improve`` and ``explain --summary`` all check them (docs/task-files.md)."""

from __future__ import annotations

from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from manigraph_tools.episode_plan import EpisodeOptions


def checked_files(episodes: EpisodeOptions) -> tuple[str | None, int, str | None]:
    """The task file's text and blocks, and the rules file's text, each checked here (a bad
    one stops the command naming the file, the line and the field); no task file: None, the
    ``--blocks`` asked for, None."""
    task_file = episodes.task_text()
    rules = episodes.rules_text()
    if task_file is None:
        return None, episodes.blocks, None
    from manigraph_sim.family import task_file_family

    blocks = task_file_family().check_task_file(
        task_file, str(episodes.task_file), rules, str(episodes.rules)
    )
    return task_file, blocks, rules
