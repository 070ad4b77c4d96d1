"""Arm contacts with objects other than the one being moved, from SAPIEN's contact reports,
over six-block physics episodes, with and without arm-link collision checking.

In process (no bus): the physics backend, the planner's policy and the skills' own
``PickAndPlace`` with ``PandaMotionDriver`` (``run_episode``). After every physics step the
world's contacts are read; a contact counts when one body is a Panda link, the other is a
block, a cover, a box or the table, it is not the object the current action moves, and the
contact pushes (impulse > 0). Links 0 and 1 on the table are the robot standing on it.

    python bench/bench_arm_contacts.py --episodes 20 --checks off   # before
    python bench/bench_arm_contacts.py --episodes 20 --checks on    # after

Prints one line per episode with contacts, then a JSON summary (episodes, success rate,
episodes with an arm contact, contact events as (action, link, body) triples).
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from collections import Counter

import numpy as np

from manigraph_lab.episode_loop import StepClock, run_episode
from manigraph_lab.in_process import InProcessJointTransport
from manigraph_planner.policies.base import load_policy
from manigraph_shared.messages import EpisodeRequest
from manigraph_sim.physics.backend import PhysicsBackend
from manigraph_skills.drivers.base import Motion
from manigraph_skills.drivers.panda_motion import PandaMotionDriver

ROBOT_ON_TABLE = {"panda_link0", "panda_link1"}


class WatchedDriver(PandaMotionDriver):
    """The Panda motion driver, remembering which object the current action moves."""

    moving: str | None = None

    def pick(self, motion: Motion) -> None:
        self.moving = motion.object_id
        super().pick(motion)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--episodes", type=int, default=20)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--blocks", type=int, default=6)
    parser.add_argument("--task", default="stack")
    parser.add_argument("--policy", default="checkpoints/sage.pt")
    parser.add_argument("--checks", choices=("on", "off"), default="on")
    args = parser.parse_args()
    policy = load_policy(args.policy)
    events: Counter[tuple[str, str]] = Counter()
    touched_episodes = successes = 0
    failures: Counter[str] = Counter()
    seconds: list[float] = []
    for seed in range(args.seed, args.seed + args.episodes):
        seen: set[tuple[str, str, str]] = set()

        def make_driver(
            backend: PhysicsBackend,
            _clock: StepClock,
            seen: set[tuple[str, str, str]] = seen,
        ) -> WatchedDriver:
            driver = WatchedDriver(
                InProcessJointTransport(backend), check_collisions=args.checks == "on"
            )
            world = backend.world
            assert world is not None

            def watch() -> None:
                for contact in world.scene.get_contacts():
                    names = [body.entity.name for body in contact.bodies]
                    robot = [n for n in names if n.startswith("panda_")]
                    if len(robot) != 1:
                        continue
                    (link,) = robot
                    (other,) = [n for n in names if n != link]
                    if other == driver.moving or (
                        link in ROBOT_ON_TABLE and other in ("table", "ground")
                    ):
                        continue
                    if any(np.linalg.norm(p.impulse) > 0 for p in contact.points):
                        seen.add((str(driver.moving), link, other))

            world.on_step.append(watch)
            return driver

        request = EpisodeRequest(
            episode_id=f"contacts-{seed}", task=args.task, blocks=args.blocks, seed=seed
        )
        started = time.perf_counter()
        record = run_episode(policy, request, 0.0, PhysicsBackend, make_driver)  # type: ignore[arg-type]
        seconds.append(time.perf_counter() - started)
        successes += record.success
        failures.update(s.reason for s in record.steps if not s.ok and s.reason)
        if seen:
            touched_episodes += 1
            print(f"seed {seed}: {sorted(seen)}", flush=True)
        events.update((link, other.split("_")[0]) for _moving, link, other in seen)
        # Progress on stderr: a long run stopped early still says how far it got.
        print(
            f"seed {seed}: {'success' if record.success else 'failure'}, "
            f"{len(seen)} arm contacts, {seconds[-1]:.1f} s",
            file=sys.stderr,
            flush=True,
        )
    print(
        json.dumps(
            {
                "checks": args.checks,
                "task": args.task,
                "blocks": args.blocks,
                "episodes": args.episodes,
                "seeds": [args.seed, args.seed + args.episodes - 1],
                "success_rate": successes / args.episodes,
                "episodes_with_arm_contact": touched_episodes,
                "contact_events": {f"{k[0]}-{k[1]}": v for k, v in events.items()},
                "failed_skills": dict(failures),
                "median_episode_s": float(np.median(seconds)),
            }
        )
    )


if __name__ == "__main__":
    main()
