"""The physics stack in real time, through every service: wall seconds per episode against
simulated seconds, and the Scene and JointState rates the recorder saw on the bus.

    uv run python bench/bench_realtime.py --policy checkpoints/sage.pt --blocks 4 --episodes 5

runs ``manigraph up --sim physics --realtime ... --record <tmp>.mcap --json`` and prints one
JSON object: the episode summary's wall and simulated seconds, and per-episode stream rates
(``manigraph_testkit.stream_rates``). Extra arguments after ``--`` go to ``manigraph up``.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
from pathlib import Path

from manigraph_testkit.stream_rates import stream_rates, summary


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--policy", default="checkpoints/sage.pt")
    parser.add_argument("--task", default="stack")
    parser.add_argument("--blocks", type=int, default=4)
    parser.add_argument("--episodes", type=int, default=5)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--record", type=Path, help="keep the MCAP log here")
    parser.add_argument("up_args", nargs="*", help="more `manigraph up` flags (after --)")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as scratch:
        log = args.record or Path(scratch) / "realtime.mcap"
        command = [
            sys.executable,
            "-m",
            "manigraph_shared.cli",
            "up",
            "--sim",
            "physics",
            "--realtime",
            "--policy",
            args.policy,
            "--task",
            args.task,
            "--blocks",
            str(args.blocks),
            "--episodes",
            str(args.episodes),
            "--seed",
            str(args.seed),
            "--record",
            str(log),
            "--json",
            *args.up_args,
        ]
        print("$ manigraph " + " ".join(command[3:]), file=sys.stderr)
        done = subprocess.run(command, stdout=subprocess.PIPE, text=True, check=False)
        if done.returncode != 0:
            print(f"manigraph up failed ({done.returncode})", file=sys.stderr)
            return done.returncode
        episodes = json.loads(done.stdout.strip().splitlines()[-1])
        streams = summary(stream_rates(log))
    report = {
        "load": os.getloadavg()[0],
        "success_rate": episodes["success_rate"],
        "mean_wall_seconds": round(float(episodes["mean_seconds"]), 2),
        "mean_sim_seconds": episodes.get("mean_sim_seconds"),
        "realtime_factor": episodes.get("realtime_factor"),
        "wall_seconds": [r["seconds"] for r in episodes["results"]],
        "sim_seconds": [r["sim_seconds"] for r in episodes["results"]],
        **{k: v for k, v in streams.items() if k != "per_episode"},
        "per_episode": streams.get("per_episode", []),
    }
    print(json.dumps(report))
    return 0


if __name__ == "__main__":
    sys.exit(main())
