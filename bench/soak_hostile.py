"""The soak's checks for issue #48 (``bench/soak.py``): hostile task files, a flood of forged
Actions during real episodes, and the emergency-stop latch across kill -9 of sim and skills.

Each returns ``(counts, lost, held, notes)`` as every soak check does.
"""

from __future__ import annotations

import signal
import threading
import time

from soak_episodes import EpisodesMeanwhile  # bench/soak_episodes.py
from soak_stack import SoakStack  # bench/soak_stack.py

from manigraph_shared.errors import BusError, RequestRefused
from manigraph_shared.messages import (
    Action,
    EpisodeEvent,
    EpisodeRequest,
    JointTrajectoryCommand,
    RobotCommand,
    ServiceStatus,
    SkillStatus,
)
from manigraph_testkit.hostile_task_files import matching_bomb

#: Generous on a loaded machine; ``bench/bench_hostile_task_files.py`` measures the 0.5 s target.
TASK_FILE_LIMIT = 5.0


def hostile_task_files(soak: SoakStack):  # type: ignore[no-untyped-def]
    """13 KB and 60 KB files whose goals accept a value nobody has: refused, quickly."""

    def run():  # type: ignore[no-untyped-def]
        results = []
        for size in (13_000, 60_000):
            toml = matching_bomb(size)
            request = EpisodeRequest(episode_id=f"bomb-{size}", task="file", task_file=toml)
            started = time.perf_counter()
            try:
                soak.bus.request(request, EpisodeEvent, timeout=30.0)
                kind = "accepted"
            except RequestRefused:
                kind = "refused"
            except BusError:
                kind = "no answer"
            results.append((size, kind, time.perf_counter() - started))
        held = all(kind == "refused" and t < TASK_FILE_LIMIT for _, kind, t in results)
        counts = "; ".join(f"{s >> 10} KiB: {kind} in {t:.2f} s" for s, kind, t in results)
        return counts, "-", held, ""

    return run


def forged_actions(soak: SoakStack, count: int = 10_000):  # type: ignore[no-untyped-def]
    """``count`` forged Actions (each refused by skills with a status the sim also receives)
    while real episodes run: no robot command may be dropped from the sim's inbox."""

    def run():  # type: ignore[no-untyped-def]
        dropped: list[str] = []
        soak.bus.subscribe(
            ServiceStatus,
            lambda s: dropped.append(s.detail) if "inbox full" in s.detail else None,
            key="manigraph/status/sim",
        )
        episodes = EpisodesMeanwhile(soak)
        episodes.start()
        try:
            time.sleep(2.0)
            for i in range(count):
                soak.bus.publish(
                    Action(
                        decision_id=f"forged:{i}",
                        episode_id="forged",
                        scene_sequence=i,
                        object_id="block_0",
                        goal_id="goal_0",
                        policy="forger",
                        stamp=time.time(),
                    )
                )
            time.sleep(5.0)
        finally:
            episodes.stop()
        robot_drops = [d for d in dropped if "robot" in d.rsplit("(", 1)[-1]]
        held = not robot_drops and episodes.hung == 0 and episodes.failed == 0
        counts = f"{count} forged Actions; {episodes.summary()}"
        lost = f"robot commands dropped by the sim: {len(robot_drops)} reports"
        return counts, lost, held, episodes.failures() or (dropped[-1][:120] if dropped else "")

    return run


def estop_latch(soak: SoakStack):  # type: ignore[no-untyped-def]
    """Stop; kill -9 sim and skills and start them again; a reset and a forged Action move
    nothing; resume; a reset is accepted."""

    def run():  # type: ignore[no-untyped-def]
        running, bus = soak.running, soak.bus
        moved: list[object] = []
        finals: dict[str, SkillStatus] = {}
        lock = threading.Lock()
        bus.subscribe(RobotCommand, moved.append)
        bus.subscribe(JointTrajectoryCommand, moved.append)

        def final(status: SkillStatus) -> None:
            if status.state.terminal:
                with lock:
                    finals[status.decision_id] = status

        bus.subscribe(SkillStatus, final)
        stop = running.run("stop", "--reason", "soak latch", timeout=120)
        for name in ("sim", "skills"):
            running.stop(name, signal.SIGKILL)
        time.sleep(1.0)
        running.start("sim", "sim")
        running.start("skills", "skills")
        running.wait_alive(bus, "sim", "skills", timeout=600)
        before = len(moved)
        try:
            bus.request(
                EpisodeRequest(episode_id="latched", task="stack", blocks=3),
                EpisodeEvent,
                timeout=30,
            )
            reset = "accepted"
        except RequestRefused as exc:
            reset = "refused estop_engaged" if "estop_engaged" in str(exc) else "refused"
        except BusError:
            reset = "no answer"
        bus.publish(
            Action(
                decision_id="latched:0",
                episode_id="latched",
                scene_sequence=1,
                object_id="block_0",
                goal_id="goal_0",
                policy="another-decider",
                stamp=time.time(),
            )
        )
        deadline = time.monotonic() + 10
        while "latched:0" not in finals and time.monotonic() < deadline:
            time.sleep(0.05)
        time.sleep(0.5)
        commands = len(moved) - before
        refused = finals.get("latched:0")
        resumed_at = time.monotonic()
        resume = running.run("resume", timeout=120)
        accepted = None
        while accepted is None and time.monotonic() - resumed_at < 30:
            try:
                bus.request(
                    EpisodeRequest(episode_id="resumed", task="stack", blocks=3), EpisodeEvent, 5.0
                )
                accepted = time.monotonic() - resumed_at
            except (RequestRefused, BusError):
                time.sleep(0.1)
        held = (
            stop.returncode == 0
            and resume.returncode == 0
            and reset == "refused estop_engaged"
            and refused is not None
            and refused.reason == "stopped"
            and commands == 0
            and accepted is not None
        )
        counts = (
            f"reset after kill -9 of sim + skills: {reset}; Action: "
            f"{refused.reason if refused else 'no status'}; robot commands {commands}; "
            f"resume to an accepted reset: {accepted if accepted is None else f'{accepted:.2f} s'}"
        )
        return counts, "-", held, ""

    return run
