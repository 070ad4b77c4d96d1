"""A demonstrator of your own: a client that plays the planner's part over the bus.

The click page (``manigraph demo-ui``) is one such client; this is another, to start from. A
teleoperation device, a speech interface or a scripted teacher decides in :func:`decide`
instead of the rule below. Every ``Action`` it publishes is a demonstration: this script writes
each episode's scenes and actions to its own log (``-o``), and ``manigraph up --record`` keeps
them too; ``manigraph train`` learns from either (docs/task-files.md).

    uv run manigraph up --policy none --port 7600 &              # a stack with no planner
    uv run python examples/demonstrator.py --port 7600 \\
        --task-file examples/tasks/kitting.toml --episodes 20 -o demos.mcap
    uv run manigraph train demos.mcap --arch sage -o runs/kitting.pt

On a secure stack (``up --secure``) it presents the ``demo-ui`` identity, the one the router
lets both reset the world and publish actions: ``--tls-dir DIR --tls-identity demo-ui``
(``up`` prints DIR). As any other identity its resets and actions are refused: a reset
refused or unanswered ends it at once, in one line that says which (:func:`reset_problem`).
"""

from __future__ import annotations

import argparse
import queue
import sys
import time
from pathlib import Path

from manigraph_shared.acceptance import admits
from manigraph_shared.bus import Bus
from manigraph_shared.bus_config import add_bus_arguments, bus_config_from_args
from manigraph_shared.demonstrations import DemonstrationLog, stamp_times
from manigraph_shared.errors import BusError, RequestRefused
from manigraph_shared.messages import (
    Action,
    EpisodeEvent,
    EpisodePhase,
    EpisodeRequest,
    Scene,
    SkillStatus,
)

POLICY = "demonstrator"
#: Seconds a reset may take (a physics world lays out its objects in a few).
RESET_WAIT = 30.0


def decide(scene: Scene) -> tuple[str, str] | None:
    """The teacher: the highest free object into the lowest free goal that accepts it."""
    goals = sorted(
        (g for g in scene.goals if g.visible and not g.filled), key=lambda g: g.position.z
    )
    objects = sorted(
        (o for o in scene.objects if o.visible and not o.filled), key=lambda o: -o.position.z
    )
    for goal in goals:
        for obj in objects:
            if obj.category.value == goal.category.value and admits(
                goal.accepts, obj.id, obj.size.as_tuple(), obj.attributes
            ):
                return obj.id, goal.id
    return None


Demonstration = tuple[EpisodeEvent, list[tuple[Scene, Action]], EpisodeEvent]


def demonstrate(
    bus: Bus, request: EpisodeRequest, inbox: queue.Queue[object], wait: float
) -> Demonstration:
    """One episode: reset the world, then decide on each fresh scene until it ends."""
    asked = time.monotonic()
    try:
        start = bus.request(request, EpisodeEvent, timeout=RESET_WAIT)
    except BusError as exc:
        raise ResetFailed(reset_problem(bus, exc, time.monotonic() - asked)) from None
    steps: list[tuple[Scene, Action]] = []
    scene: Scene | None = None
    deadline = time.monotonic() + wait  # for the next decision, or the episode's end
    while True:
        item = next_item(inbox, deadline)
        ours = getattr(item, "episode_id", None) == request.episode_id
        if isinstance(item, EpisodeEvent) and ours and item.phase is EpisodePhase.END:
            return start, steps, item
        if not isinstance(item, Scene) or item.episode_id != request.episode_id:
            continue
        if scene is not None and item.sequence <= scene.sequence:
            continue  # an older scene than the one decided on
        scene = item
        choice = decide(scene)
        if choice is None:
            continue  # nothing to do: the world ends the episode
        action = Action(
            decision_id=f"{request.episode_id}:{len(steps)}",
            episode_id=request.episode_id,
            scene_sequence=scene.sequence,
            object_id=choice[0],
            goal_id=choice[1],
            policy=POLICY,
            stamp=time.time(),
        )
        bus.publish(action)
        steps.append((scene, action))
        print(f"  {action.decision_id}: {choice[0]} -> {choice[1]}", file=sys.stderr)
        end = wait_for_skill(inbox, action, time.monotonic() + wait)
        if end is not None:  # the world ended the episode before the skill's last word
            return start, steps, end
        deadline = time.monotonic() + wait


class ResetFailed(Exception):
    """The world could not be reset; the message says why, in one line."""


def reset_problem(bus: Bus, error: BusError, seconds: float) -> str:
    """Why a reset failed: refused by the sim (a bad task file, a stopped robot), or not
    answered. The router ends at once, with no reply, a query this identity may not send, as
    it does one nobody serves: the sim's liveliness tells the two apart."""
    if isinstance(error, RequestRefused):
        return f"the world refused the episode: {error}"
    if "sim" not in bus.alive_services(timeout=1.0):
        return "no sim answers resets on this bus: is a stack running (manigraph up --policy none)?"
    if seconds < RESET_WAIT / 2:
        return (
            "the reset was refused without an answer although the sim is alive: this identity "
            "may not reset the world (access denied by the router; on a secure stack present "
            "--tls-identity demo-ui)"
        )
    return f"the sim did not answer the reset within {RESET_WAIT:g} s: is it busy?"


def wait_for_skill(
    inbox: queue.Queue[object], action: Action, deadline: float
) -> EpisodeEvent | None:
    """Until the skill of ``action`` has finished (the scenes meanwhile are stale), or its
    episode has ended (that end, then)."""
    while True:
        item = next_item(inbox, deadline)
        ours = getattr(item, "decision_id", None) == action.decision_id
        if isinstance(item, SkillStatus) and ours and item.state.terminal:
            return None
        ended = getattr(item, "episode_id", None) == action.episode_id
        if isinstance(item, EpisodeEvent) and ended and item.phase is EpisodePhase.END:
            return item


def next_item(inbox: queue.Queue[object], deadline: float) -> object:
    """The next message, or ``queue.Empty`` once ``deadline`` (monotonic) has passed: scenes
    keep coming while nothing else does."""
    left = deadline - time.monotonic()
    if left <= 0:
        raise queue.Empty
    return inbox.get(timeout=left)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--task-file", type=Path, required=True, help="the task, as a file")
    parser.add_argument("--episodes", type=int, default=20, help="demonstrations to give")
    parser.add_argument("--seed", type=int, default=0, help="seed of the first episode")
    parser.add_argument("-o", "--output", type=Path, help="MCAP file of the demonstrations")
    parser.add_argument(
        "--wait", type=float, default=60.0, help="seconds for a scene or a skill's end"
    )
    add_bus_arguments(parser)
    args = parser.parse_args()
    text = args.task_file.read_text()
    inbox: queue.Queue[object] = queue.Queue()
    log = DemonstrationLog(args.output, stamp_times) if args.output else None
    with Bus.open(bus_config_from_args(args, wait_seconds=5.0)) as bus:
        for kind in (Scene, SkillStatus, EpisodeEvent):
            bus.subscribe(kind, inbox.put)
        succeeded = 0
        for index in range(args.episodes):
            request = EpisodeRequest(
                episode_id=f"demonstrator-{int(time.time())}-{index}",
                task="file",
                task_file=text,
                seed=args.seed + index,
            )
            try:
                start, steps, end = demonstrate(bus, request, inbox, args.wait)
            except ResetFailed as exc:
                print(f"demonstrator: {exc}", file=sys.stderr)
                return 1
            except queue.Empty:
                print(
                    f"demonstrator: nothing came for {args.wait:g} s: is a stack running, and may "
                    "this identity decide (demo-ui on a secure stack)?",
                    file=sys.stderr,
                )
                return 1
            succeeded += bool(end.success)
            print(
                f"{request.episode_id}: {len(steps)} steps, success {end.success}", file=sys.stderr
            )
            if log is not None:
                log.write(start, steps, end)
    if log is not None:
        log.close()
    print(f"{succeeded}/{args.episodes} demonstrations succeeded", file=sys.stderr)
    return 0 if succeeded == args.episodes else 1


if __name__ == "__main__":
    sys.exit(main())
