"""Physics dishwasher episodes in one process (issues 32 and 33): wall seconds per 10-dish
episode, success, and how far each dish came to rest from the slot nearest it.

The same classes the services run (the planner's ``DecisionMaker`` with the checkpoint, the
skills' PickAndPlace with ``PandaMotionDriver``, the SAPIEN ``PhysicsBackend``), called
directly (``manigraph_lab.episode_loop.run_episode``): no bus, so the figures are the
physics, planning and policy time alone. Through the services add the bus and the
processes' start (``manigraph up --sim physics --task dishwasher ... --json``)::

    python bench/bench_dishwasher.py --seeds 0-9
    python bench/bench_dishwasher.py --seeds 50000-50019 --profile dish.prof

Prints one line per episode, the medians, and ends with one JSON line.
"""

from __future__ import annotations

import argparse
import cProfile
import json
import os
import statistics
import time

from manigraph_lab.episode_loop import panda_driver, run_episode
from manigraph_planner.policies.base import load_policy
from manigraph_shared.messages import EpisodeRequest
from manigraph_sim.physics.backend import PhysicsBackend


def seed_range(text: str) -> list[int]:
    """``"50000-50019"`` or ``"3"`` or ``"1,4,9"``."""
    seeds: list[int] = []
    for part in text.split(","):
        low, _, high = part.partition("-")
        seeds += list(range(int(low), int(high or low) + 1))
    return seeds


def episode(policy, seed: int, objects: int, preference: str) -> dict:
    """One episode: wall seconds, success, steps and each dish's offset from its slot."""
    backends: list[PhysicsBackend] = []

    def backend_factory() -> PhysicsBackend:
        backends.append(PhysicsBackend())
        return backends[-1]

    request = EpisodeRequest(
        episode_id=f"dw{seed}",
        task="dishwasher",
        objects=objects,
        seed=seed,
        options={"preference": preference} if preference is not None else {},
    )
    started, cpu = time.perf_counter(), time.process_time()
    record = run_episode(
        policy,
        request,
        backend_factory=backend_factory,
        driver_factory=panda_driver,
    )
    wall = time.perf_counter() - started
    cpu = time.process_time() - cpu
    backend = backends[0]
    assert backend.task_world is not None
    # (A world without slot_offsets, before issue 33's fix, reports none.)
    report = getattr(backend.task_world, "slot_offsets", None)
    offsets = report() if report is not None else {}
    bowls = [mm for dish, mm in offsets.items() if dish.startswith("bowl")]
    return {
        "seed": seed,
        "success": record.success,
        "wall_s": round(wall, 2),
        "cpu_s": round(cpu, 2),
        "sim_s": record.end.sim_seconds,
        "steps": len(record.steps),
        "refused": [s.reason for s in record.steps if not s.ok],
        "goals_filled": record.end.goals_filled,
        "goals_total": record.end.goals_total,
        "max_bowl_offset_mm": round(max(bowls), 1) if bowls else None,
        "offsets_mm": {dish: round(mm, 1) for dish, mm in offsets.items()},
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--seeds", default="0-9", help="e.g. 0-9, 50000-50019, 3,7")
    parser.add_argument("--objects", type=int, default=10)
    parser.add_argument("--preference", default="top-bottom")
    parser.add_argument("--policy", default="checkpoints/dishwasher-top-bottom-sage.pt")
    parser.add_argument("--profile", help="write a cProfile of all episodes here")
    args = parser.parse_args()
    policy = load_policy(args.policy)
    profiler = cProfile.Profile() if args.profile else None
    rows = []
    for seed in seed_range(args.seeds):
        if profiler is not None:
            profiler.enable()
        row = episode(policy, seed, args.objects, args.preference)
        if profiler is not None:
            profiler.disable()
        rows.append(row)
        print(
            f"seed {seed}: {'ok  ' if row['success'] else 'FAIL'} {row['wall_s']:6.1f} s wall "
            f"{row['cpu_s']:6.1f} s cpu {row['sim_s'] or 0:6.1f} s sim, {row['steps']} steps, "
            f"goals {row['goals_filled']}/{row['goals_total']}, "
            f"max bowl offset {row['max_bowl_offset_mm']} mm, refused {row['refused']}",
            flush=True,
        )
    if profiler is not None:
        profiler.dump_stats(args.profile)
    walls = [r["wall_s"] for r in rows]
    bowl_offsets = [r["max_bowl_offset_mm"] for r in rows if r["max_bowl_offset_mm"] is not None]
    summary = {
        "bench": "dishwasher",
        "seeds": args.seeds,
        "objects": args.objects,
        "preference": args.preference,
        "episodes": len(rows),
        "successes": sum(r["success"] for r in rows),
        "median_wall_s": round(statistics.median(walls), 2),
        "mean_wall_s": round(statistics.fmean(walls), 2),
        "max_wall_s": max(walls),
        "median_cpu_s": round(statistics.median(r["cpu_s"] for r in rows), 2),
        "median_sim_s": round(statistics.median(r["sim_s"] or 0.0 for r in rows), 2),
        "max_bowl_offset_mm": max(bowl_offsets) if bowl_offsets else None,
        "bowls_over_10mm": sum(
            mm > 10.0
            for r in rows
            for dish, mm in r["offsets_mm"].items()
            if dish.startswith("bowl")
        ),
        "load": os.getloadavg(),
        "failed_seeds": [r["seed"] for r in rows if not r["success"]],
    }
    print(
        f"median {summary['median_wall_s']} s wall ({summary['median_cpu_s']} s cpu), "
        f"{summary['successes']}/{len(rows)} succeeded"
    )
    print(json.dumps(summary))


if __name__ == "__main__":
    main()
