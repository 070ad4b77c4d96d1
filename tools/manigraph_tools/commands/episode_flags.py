"""The episode flags ``manigraph run`` and ``manigraph up`` share, and the plan they give."""

from __future__ import annotations

import argparse
import secrets
import time

from manigraph_shared.options import add_option_arguments, options_from_args
from manigraph_tools.episode_plan import EpisodeOptions, EpisodePlan


def episode_arguments(parser: argparse.ArgumentParser) -> None:
    add_option_arguments(parser.add_argument_group("episodes"), EpisodeOptions)


def plan_from_args(args: argparse.Namespace, episodes: int) -> EpisodePlan:
    options = options_from_args(EpisodeOptions, args)
    # Seconds alone repeat: two runs started in one second (cells driven side by side) would
    # give their episodes the same ids, and the logs would mix them.
    run_id = f"{options.label()}-{int(time.time())}-{secrets.token_hex(2)}"
    return options.plan(episodes, run_id=run_id)
