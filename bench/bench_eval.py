"""Evaluation speed: decisions per second of in-process episodes, per checkpoint and K."""

from __future__ import annotations

import argparse
from pathlib import Path

from manigraph_lab.evaluate import EvalSpec, evaluate
from manigraph_planner.policies import load_policy


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument(
        "--policies",
        nargs="+",
        default=["expert", *map(str, sorted(Path("checkpoints").glob("*.pt")))],
    )
    parser.add_argument("--blocks", type=int, nargs="+", default=[3, 9, 40])
    parser.add_argument("--episodes", type=int, default=20)
    args = parser.parse_args()
    print(f"{'policy':>24} {'K':>4} {'decisions/s':>12} {'success':>8}")
    for name in args.policies:
        policy = load_policy(name)
        for k in args.blocks:
            summary = evaluate(policy, EvalSpec("stack", k, episodes=args.episodes), progress=None)
            print(
                f"{name:>24} {k:>4} {summary['decisions_per_second']:>12.0f} "
                f"{summary['success_rate']:>8.2f}"
            )


if __name__ == "__main__":
    main()
