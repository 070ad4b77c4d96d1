"""Does the physics world's box layout alone cost a policy episodes? The same seeds of a box
task in the geometric world (no physics), once in the demonstrations' box layout and once in
the physics world's (``manigraph_blocks.sim.physics_boxes.PHYSICS_BOXES``), in process.

    python bench/bench_box_layout.py --policy checkpoints/sage.pt --episodes 20
"""

from __future__ import annotations

import argparse
import json
from functools import partial

from manigraph_lab.episode_loop import run_episode
from manigraph_planner.policies.base import load_policy
from manigraph_shared.messages import EpisodeRequest
from manigraph_sim.geometric.backend import GeometricBackend


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--policy", default="checkpoints/sage.pt")
    parser.add_argument("--task", default="box-rearrangement")
    parser.add_argument("--blocks", type=int, default=4)
    parser.add_argument("--episodes", type=int, default=20)
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args()
    policy = load_policy(args.policy)
    layouts = {
        "geometric": GeometricBackend,
        "physics": partial(GeometricBackend, box_geometry="physics"),
    }
    seeds = range(args.seed, args.seed + args.episodes)
    for name, factory in layouts.items():
        failed = [
            seed
            for seed in seeds
            if not run_episode(
                policy,
                EpisodeRequest(
                    episode_id=f"layout-{seed}", task=args.task, blocks=args.blocks, seed=seed
                ),
                0.0,
                factory,
            ).success
        ]
        print(
            json.dumps(
                {
                    "layout": name,
                    "task": args.task,
                    "blocks": args.blocks,
                    "episodes": args.episodes,
                    "success_rate": 1 - len(failed) / args.episodes,
                    "failed_seeds": failed,
                }
            )
        )


if __name__ == "__main__":
    main()
