"""IK solve time for the Panda (Pinocchio, damped least squares): median over top-down
targets spread over the task workspace, each solved from the rest pose. Target: <= 2 ms."""

from __future__ import annotations

import argparse
import time

import numpy as np

from manigraph_skills.motion import HOME_Q, IKSolver, PandaModel, PlanConfig
from manigraph_skills.motion.model import top_down


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--targets", type=int, default=1000)
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args()
    ik = IKSolver(PandaModel())
    rng = np.random.default_rng(args.seed)
    seconds, iterations, failures = [], [], 0
    for _ in range(args.targets):
        target = top_down(
            [rng.uniform(0.3, 0.7), rng.uniform(-0.35, 0.35), rng.uniform(0.02, 0.3)],
            yaw=PlanConfig().hand_yaw + rng.uniform(-np.pi / 4, np.pi / 4),
        )
        started = time.perf_counter()
        result = ik.solve(target, HOME_Q)
        seconds.append(time.perf_counter() - started)
        iterations.append(result.iterations)
        failures += not result.ok
    median_ms = float(np.median(seconds)) * 1000
    print(f"IK, {args.targets} top-down targets in the workspace, from the rest pose")
    print(f"median {median_ms:.3f} ms  (vs 2 ms target: {median_ms / 2:.3f})")
    print(f"p95    {float(np.percentile(seconds, 95)) * 1000:.3f} ms")
    print(f"median iterations {int(np.median(iterations))}, failures {failures}")


if __name__ == "__main__":
    main()
