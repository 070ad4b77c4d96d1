"""Physics speed on this CPU, in one process (sim backend + Panda motion driver, no bus):
wall seconds per PickAndPlace (target <= 0.2 s at K = 6) and per K-block stacking episode
(the expert's moves), per cover PickAndPlace (lifted off its box by the handle onto its
storage place), physics steps per second, IK and planning time. End-to-end figures through every
service come from ``manigraph up --sim physics ... --episodes N`` (its mean_seconds)."""

from __future__ import annotations

import argparse
import json
import os
import time

import numpy as np

from manigraph_lab.in_process import InProcessJointTransport
from manigraph_shared.messages import Action, EpisodeRequest, SkillState
from manigraph_shared.workspace import Workspace
from manigraph_sim.physics.backend import PhysicsBackend
from manigraph_skills.drivers.panda_motion import PandaMotionDriver
from manigraph_skills.motion import HOME_Q, GraspPlanner, IKSolver
from manigraph_skills.motion.model import top_down
from manigraph_skills.pick_and_place import PickAndPlace


def move(
    backend: PhysicsBackend, skill: PickAndPlace, step: int, object_id: str, goal_id: str
) -> tuple[float, bool]:
    """One PickAndPlace: wall seconds, succeeded."""
    scene = backend.scene(time.time())
    assert scene is not None
    action = Action(
        decision_id=f"{scene.episode_id}:{step}",
        episode_id=scene.episode_id,
        scene_sequence=scene.sequence,
        object_id=object_id,
        goal_id=goal_id,
        policy="bench",
        stamp=time.time(),
    )
    t = time.perf_counter()
    status = skill.execute(action, scene, lambda _s: None)
    backend.skill_finished(status)
    return time.perf_counter() - t, status.state is SkillState.SUCCEEDED


def cover_move(backend: PhysicsBackend, skill: PickAndPlace, seed: int) -> tuple[float, bool]:
    """A cover off its box onto the storage place (box packing, one block)."""
    request = EpisodeRequest(episode_id=f"c{seed}", task="box-pack", blocks=1, seed=seed)
    backend.reset(request, time.time())
    return move(backend, skill, 0, "cover_0", "storage_0")


def episode(backend: PhysicsBackend, skill: PickAndPlace, blocks: int, seed: int) -> dict:
    backend.reset(
        EpisodeRequest(episode_id=f"b{seed}", task="stack", blocks=blocks, seed=seed), time.time()
    )
    started = time.perf_counter()
    moves, steps_before = [], backend.physics_steps
    for i in range(blocks):
        moves.append(move(backend, skill, i, f"block_{blocks - 1 - i}", f"goal_{i}"))
    end = backend.end_event(time.time())
    return {
        "seconds": time.perf_counter() - started,
        "moves": moves,
        "steps": backend.physics_steps - steps_before,
        "success": bool(end is not None and end.success),
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--blocks", type=int, nargs="+", default=[3, 6])
    parser.add_argument("--episodes", type=int, default=5)
    parser.add_argument(
        "--collision-checks",
        choices=("on", "off"),
        default="on",
        help="arm-link collision checking of every motion (off: the hand's path only)",
    )
    args = parser.parse_args()
    backend = PhysicsBackend()
    driver = PandaMotionDriver(
        InProcessJointTransport(backend), check_collisions=args.collision_checks == "on"
    )
    skill = PickAndPlace(driver, Workspace())
    timestep = backend.config.timestep

    ik, planner = IKSolver(driver.model), GraspPlanner(driver.model)
    ik_times, plan_times = [], []
    for _ in range(200):
        t = time.perf_counter()
        ik.solve(top_down([0.5, 0.1, 0.1]), HOME_Q)
        ik_times.append(time.perf_counter() - t)
    for _ in range(20):
        t = time.perf_counter()
        pick = planner.pick(HOME_Q, np.array([0.5, 0.2, 0.06]))
        planner.release(planner.place(pick.final, np.array([0.4, -0.2, 0.02])).final)
        plan_times.append(time.perf_counter() - t)
    print(f"physics: timestep {timestep * 1000:.1f} ms, in process (no bus)")
    print(
        f"IK median {np.median(ik_times) * 1000:.3f} ms (vs 2 ms: {np.median(ik_times) / 2e-3:.3f})"
    )
    print(
        f"planning one PickAndPlace (pick + place + release) {np.median(plan_times) * 1000:.1f} ms"
    )
    print(
        f"{'K':>3} {'episodes':>8} {'success':>8} {'s/episode':>10} {'s/P&P':>7} "
        f"{'P&P/0.2 s':>10} {'steps/s':>9} {'x realtime':>10}"
    )
    cells = []
    for blocks in args.blocks:
        runs = [episode(backend, skill, blocks, seed) for seed in range(args.episodes)]
        move_seconds = [s for run in runs for s, _ in run["moves"]]
        wall = sum(run["seconds"] for run in runs)
        steps = sum(run["steps"] for run in runs)
        success = np.mean([run["success"] for run in runs])
        per_move = float(np.median(move_seconds))
        print(
            f"{blocks:>3} {args.episodes:>8} {success:>8.2f} "
            f"{np.median([r['seconds'] for r in runs]):>10.2f} {per_move:>7.3f} "
            f"{per_move / 0.2:>10.3f} {steps / wall:>9.0f} {steps * timestep / wall:>10.1f}"
        )
        cells.append(
            {
                "k": blocks,
                "success": round(float(success), 3),
                "pick_and_place_p50_s": round(per_move, 3),
                "limit_s": 0.2,
                "episode_p50_s": round(float(np.median([r["seconds"] for r in runs])), 2),
                "steps_per_s": round(steps / wall),
            }
        )
    covers = [cover_move(backend, skill, seed) for seed in range(args.episodes)]
    print(
        f"cover PickAndPlace (box off, onto storage): median "
        f"{np.median([s for s, _ in covers]):.3f} s, {sum(ok for _, ok in covers)}/{len(covers)} "
        "succeeded"
    )
    print(
        json.dumps(
            {
                "bench": "physics",
                "load": round(os.getloadavg()[0], 2),
                "ik_p50_ms": round(float(np.median(ik_times)) * 1000, 3),
                "plan_p50_ms": round(float(np.median(plan_times)) * 1000, 1),
                "cells": cells,
                "cover_pick_and_place_p50_s": round(float(np.median([s for s, _ in covers])), 3),
            }
        )
    )


if __name__ == "__main__":
    main()
