"""The ``--threads`` option of every command that trains or evaluates a torch policy."""

from __future__ import annotations

import argparse

from manigraph_shared.errors import ConfigError

HELP = (
    "torch threads (default 2); 1 on a busy machine: threads that wait for each other on a "
    "loaded CPU made an epoch 50x slower here"
)


def add_threads_option(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--threads", type=int, default=2, help=HELP)


def use_threads(count: int) -> None:
    """Set torch's intra-op threads, refusing a count below 1 with the option's name."""
    import torch

    if count < 1:
        raise ConfigError("threads", f"must be >= 1, got {count}")
    torch.set_num_threads(count)
