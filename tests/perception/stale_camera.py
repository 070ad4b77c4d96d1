"""One stale-camera check for every pipeline (issue 50): a service on a real bus is shown a
good frame, then a bad one, then the good one again with its old stamp (a frozen camera),
then nothing, then the next episode's layout and a bad frame. At no point is an old world
published as a fresh observation: the status says why each time with the age of the last
good Scene, which a bad or frozen frame has served again, stale, with its own stamp, at most
once a second, and never as the next episode's."""

from __future__ import annotations

import contextlib
import queue
import time
from collections.abc import Callable
from pathlib import Path

from manigraph_shared.bus import Bus
from manigraph_shared.messages import Message, Scene, ServiceStatus, TaskLayout
from manigraph_testkit.testing import stack

#: A frame's messages, given its sequence and stamp.
FrameMaker = Callable[[int, float], list[Message]]


def _drain(scenes: queue.Queue[Scene], seconds: float) -> list[Scene]:
    got, deadline = [], time.monotonic() + seconds
    while (left := deadline - time.monotonic()) > 0:
        with contextlib.suppress(queue.Empty):
            got.append(scenes.get(timeout=left))
    return got


def _status_saying(statuses: queue.Queue[ServiceStatus], *words: str) -> str:
    deadline = time.monotonic() + 20
    while time.monotonic() < deadline:
        with contextlib.suppress(queue.Empty):
            detail = statuses.get(timeout=1).detail
            if all(w in detail for w in words):
                return detail
    raise AssertionError(f"no status said {words}")


def _publish(bus: Bus, messages: list[Message]) -> None:
    for message in messages:
        bus.publish(message)


def check_stale_camera(
    tmp_path: Path,
    pipeline_args: list[str],
    layout: TaskLayout,
    good: FrameMaker,
    bad: FrameMaker,
    bad_words: str,
) -> None:
    with stack(tmp_path) as running:
        running.start("router")
        running.start("perception", "perception", "--camera", "bus", *pipeline_args)
        with running.client() as bus:
            running.wait_alive(bus, "perception")
            scenes: queue.Queue[Scene] = queue.Queue()
            statuses: queue.Queue[ServiceStatus] = queue.Queue()
            bus.subscribe(Scene, scenes.put)
            bus.subscribe(ServiceStatus, statuses.put, key="manigraph/status/perception")
            bus.publish(layout)
            time.sleep(0.5)
            # A good frame: a fresh Scene of it (sent again until seen: frames are
            # latest-only samples, which the bus may drop under load).
            fresh = None
            for attempt in range(5):
                stamp = time.time()
                _publish(bus, good(attempt, stamp))
                seen = _drain(scenes, 3)
                fresh = next((s for s in seen if not s.stale and s.stamp == stamp), None)
                if fresh is not None:
                    break
            assert fresh is not None, "no fresh Scene of a good frame"
            old = fresh.stamp
            # A bad frame: named with the last good Scene's age; that Scene again, stale.
            _publish(bus, bad(10, time.time()))
            _status_saying(statuses, bad_words, "last good scene", "s old")
            # A frozen camera: the good frame again and again with its old stamp.
            started = time.monotonic()
            seen = []
            for _ in range(12):
                _publish(bus, good(20, old))
                seen += _drain(scenes, 0.25)
            seen += _drain(scenes, 0.5)
            seconds = time.monotonic() - started
            assert seen, "the last good Scene was not served again while the camera froze"
            assert all(s.stale and s.stamp == old for s in seen), [
                (s.stale, s.stamp - old) for s in seen
            ]
            assert len(seen) <= seconds + 2, f"{len(seen)} stale Scenes in {seconds:.1f} s"
            _status_saying(
                statuses, "no usable frame for", "last good scene", "no newer than the last one"
            )
            # Nothing at all: said in the status; nothing fresh, at most the old world, stale.
            silent = _drain(scenes, 2.5)
            assert all(s.stale and s.stamp == old for s in silent)
            _status_saying(statuses, "no usable frame for", "last good scene")
            # The next episode: the last one's world is never served again as its own.
            bus.publish(layout.replace(episode_id="next", stamp=time.time()))
            time.sleep(0.5)
            _publish(bus, bad(30, time.time()))
            detail = _status_saying(statuses, bad_words, "frame 30")
            assert "last good scene" not in detail, detail
            assert _drain(scenes, 1.5) == []
