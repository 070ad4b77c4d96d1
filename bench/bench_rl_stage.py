"""RL training speed: seconds per PPO stage (2,000 interactions) per baseline and torch threads.

Prints the median over ``--repeats`` runs of one stage (K = ``--blocks``) trained from scratch,
the number ``manigraph rl-compare`` multiplies by 8 stages x 3 seeds per baseline.
"""

from __future__ import annotations

import argparse
import statistics
import tempfile
import time
from pathlib import Path

import torch

from manigraph_lab.rl.baselines import BASELINES, PPOSettings, Stage, train_stage


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--baselines", nargs="+", default=["rl-mlp", "rl-gnn-seq"])
    parser.add_argument("--threads", type=int, nargs="+", default=[1, 2])
    parser.add_argument("--blocks", type=int, default=5)
    parser.add_argument("--repeats", type=int, default=3)
    args = parser.parse_args()
    settings = PPOSettings()
    stage = Stage(f"K{args.blocks}", (args.blocks,), (args.blocks,))
    print(f"{'baseline':>12} {'threads':>8} {'median s/stage':>15} {'interactions/s':>15}")
    with tempfile.TemporaryDirectory() as folder:
        for name in args.baselines:
            for threads in args.threads:
                torch.set_num_threads(threads)
                times = []
                for repeat in range(args.repeats):
                    started = time.perf_counter()
                    out = Path(folder) / f"{name}-{threads}-{repeat}.zip"
                    train_stage(BASELINES[name], stage, settings, repeat, None, out, list)
                    times.append(time.perf_counter() - started)
                median = statistics.median(times)
                rate = settings.steps_per_stage / median
                print(f"{name:>12} {threads:>8} {median:>15.2f} {rate:>15.0f}")


if __name__ == "__main__":
    main()
