"""What hostile camera input costs a running RGB-D perception service (issue 48), beside
normal frames measured in the same run.

A router and ``manigraph perception --pipeline rgbd --camera bus`` run as processes on a
loopback port of their own; this process is the camera, publishing a colour + depth frame
of one red block (drawn analytically at the sim camera's calibration) every ``1 / --hz`` s
throughout, and, on a session of its own, the forger. Three phases of at least ``--phase``
seconds each, one after the other:

1. ``reference``: normal frames only;
2. ``huge depth``: one forged frame whose depth is 18000 x 18000 zeros (a valid 16-bit PNG
   of 630 kB, 648 MB decoded) with a colour image of its sequence (target: perception
   grows <= 50 MB, <= 1 frame of Scenes lost);
3. ``unpaired``: ``--halves`` depth images (default 10,000) of the calibrated size and
   ``--half-kb`` each (default 400, as in the issue), with descending sequences, that never
   pair (target: <= 50 MB left after it).

Per phase: perception's RSS growth (peak and left 2 s after its end, read every 20 ms
from /proc; and what is left of it in private memory, RssAnon), the frames sent and the
fresh Scenes received for them (lost = sent - received; the newest-first pipeline may skip
a frame on a loaded machine, which the reference shows), and for the flood how many
halves perception counted. Pre-fix code is measured with ``PYTHONPATH`` pointing at an
older ``services/perception`` (``git archive <commit> services/perception | tar -x``).

    .venv/bin/python bench/bench_hostile_perception.py [--hz 5] [--phase 10] [--halves 10000]

One line per phase and a JSON summary with the load average.
"""

from __future__ import annotations

import argparse
import json
import os
import re
import sys
import tempfile
import threading
import time
from dataclasses import dataclass, field
from pathlib import Path

import cv2
import numpy as np

from manigraph_perception.calibration_file import Calibration, load_calibration
from manigraph_shared.bus import Bus
from manigraph_shared.messages import (
    CompressedImage,
    Delivery,
    DepthImage,
    GoalCategory,
    LayoutGoal,
    LayoutObject,
    ObjectCategory,
    Scene,
    ServiceStatus,
    TaskLayout,
    Vector3,
)
from manigraph_sim.physics.depth_noise import encode_depth_png
from manigraph_testkit.flood import rss_mb
from manigraph_testkit.hostile_images import zero_png
from manigraph_testkit.testing import stack

ROOT = Path(__file__).resolve().parents[1]
CALIBRATION = ROOT / "examples" / "calibration" / "sim-front.yaml"
RED = (0.5, 0.0, 0.02)
DEPTH_KEY = "manigraph/camera/front/depth"
REFUSED = "DepthImage:wrong_size"


def draw_block(calibration: Calibration) -> tuple[np.ndarray, np.ndarray]:
    """(bgr, depth in metres) of a table and one red 4 cm block at ``RED``."""
    sys.path.insert(0, str(ROOT / "tests" / "perception" / "rgbd"))
    from synthetic import draw  # the tests' analytic frames: no renderer needed

    return draw(calibration, [(RED, 0.04, "red")])


def noisy_depth_png(width: int, height: int, kb: int, seed: int = 0) -> bytes:
    """A valid 16-bit depth PNG of the calibrated size weighing about ``kb`` kB (noise in
    the top rows, zeros below): what a forger sends to be held."""
    rng = np.random.default_rng(seed)
    depth = np.zeros((height, width), np.uint16)
    rows = min(height, max(1, kb * 1024 // (2 * width)))
    depth[:rows] = rng.integers(0, 65535, (rows, width), dtype=np.uint16)
    ok, png = cv2.imencode(".png", depth)
    assert ok
    return png.tobytes()


@dataclass
class Phase:
    name: str
    started: float = 0.0
    ended: float = 0.0
    rss_before: float = 0.0
    rss_peak: float = 0.0
    rss_after: float = 0.0
    #: Private memory only (RssAnon): without the pages of code and data files a process
    #: maps on first use (Zenoh's fragment reassembly, OpenCV's PNG reader).
    anon_before: float = 0.0
    anon_after: float = 0.0
    sent: list[float] = field(default_factory=list)  # stamps of the normal frames sent
    extra: dict[str, object] = field(default_factory=dict)

    def lost(self, fresh: set[float]) -> int:
        return sum(1 for stamp in self.sent if stamp not in fresh)

    def summary(self, fresh: set[float]) -> dict[str, object]:
        return {
            "phase": self.name,
            "seconds": round(self.ended - self.started, 1),
            "rss_before_mb": round(self.rss_before, 1),
            "rss_peak_growth_mb": round(self.rss_peak - self.rss_before, 1),
            "rss_left_mb": round(self.rss_after - self.rss_before, 1),
            "anon_left_mb": round(self.anon_after - self.anon_before, 1),
            "frames_sent": len(self.sent),
            "scenes_lost": self.lost(fresh),
            **self.extra,
        }


class Camera:
    """Publishes normal frames at ``hz`` from a thread; records which phase sent which."""

    def __init__(self, bus: Bus, bgr: np.ndarray, depth: np.ndarray, hz: float) -> None:
        self.bus, self.hz = bus, hz
        ok, png = cv2.imencode(".png", bgr)
        assert ok
        self.colour, self.depth = png.tobytes(), encode_depth_png(depth)
        self.phase: Phase | None = None
        self.sequence = 1_000_000  # far above the forger's, as a camera that has run a while
        self.stop = threading.Event()
        self.thread = threading.Thread(target=self._run, daemon=True)

    def _run(self) -> None:
        next_at = time.monotonic()
        while not self.stop.is_set():
            stamp = time.time()
            self.sequence += 1
            sequence = self.sequence
            self.bus.publish(
                DepthImage(camera="front", stamp=stamp, sequence=sequence, data=self.depth)
            )
            self.bus.publish(
                CompressedImage(
                    camera="front", stamp=stamp, sequence=sequence, format="png", data=self.colour
                )
            )
            if self.phase is not None:
                self.phase.sent.append(stamp)
            next_at += 1 / self.hz
            self.stop.wait(max(0.0, next_at - time.monotonic()))


def anon_mb(pid: int) -> float:
    """Process ``pid``'s private resident memory (RssAnon) in MiB, 0 if it is gone."""
    try:
        text = Path(f"/proc/{pid}/status").read_text()
    except OSError:
        return 0.0
    match = re.search(r"RssAnon:\s+(\d+) kB", text)
    return int(match.group(1)) / 1024 if match else 0.0


class RssWatch:
    """Perception's RSS every 20 ms; the peak since ``reset``."""

    def __init__(self, pid: int) -> None:
        self.pid, self.peak, self.stop = pid, 0.0, threading.Event()
        threading.Thread(target=self._run, daemon=True).start()

    def reset(self) -> float:
        self.peak = now = rss_mb(self.pid)
        return now

    def _run(self) -> None:
        while not self.stop.wait(0.02):
            self.peak = max(self.peak, rss_mb(self.pid))


def layout() -> TaskLayout:
    v = Vector3(x=RED[0], y=RED[1], z=RED[2])
    return TaskLayout(
        episode_id="hostile",
        stamp=time.time() - 1.0,
        objects=[
            LayoutObject(
                id="block_0",
                category=ObjectCategory.BLOCK,
                position=v,
                size=Vector3(x=0.04, y=0.04, z=0.04),
            )
        ],
        goals=[LayoutGoal(id="goal_0", category=GoalCategory.BLOCK, position=v)],
    )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--hz", type=float, default=5.0, help="normal frames per second")
    parser.add_argument("--phase", type=float, default=10.0, help="seconds per phase")
    parser.add_argument("--halves", type=int, default=10_000)
    parser.add_argument("--half-kb", type=int, default=400)
    args = parser.parse_args()
    calibration = load_calibration(CALIBRATION)
    bgr, depth = draw_block(calibration)
    width, height = calibration.width, calibration.height
    huge = zero_png(18000, 18000)
    half = noisy_depth_png(width, height, args.half_kb)
    template = DepthImage(camera="front", stamp=time.time(), sequence=0, data=half).encode()
    assert template.count(b'"sequence":0') == 1
    fresh: set[float] = set()
    last_detail = [""]
    rejections: list[dict[str, int]] = [{}]
    with tempfile.TemporaryDirectory() as tmp, stack(Path(tmp)) as running:
        running.start("router")
        process = running.start(
            "perception", "perception", "--pipeline", "rgbd", "--camera", "bus",
            "--calibration", str(CALIBRATION),
        )  # fmt: skip
        # The forger has a session of its own: its flood must not fill the camera's queue.
        with running.client() as bus, running.client() as forger:
            running.wait_alive(bus, "perception")
            bus.subscribe(Scene, lambda s: None if s.stale else fresh.add(s.stamp))

            def heard(status: ServiceStatus) -> None:
                last_detail[0], rejections[0] = status.detail, status.rejections

            bus.subscribe(ServiceStatus, heard, key="manigraph/status/perception")
            bus.publish(layout())
            camera = Camera(bus, bgr, depth, args.hz)
            camera.thread.start()
            time.sleep(3.0)  # warm: the first frames allocate the pipeline's arrays
            watch = RssWatch(process.pid)
            phases: list[Phase] = []

            def run(phase: Phase, attack: object = None) -> None:
                phase.rss_before, phase.anon_before = watch.reset(), anon_mb(process.pid)
                phase.started = time.monotonic()
                camera.phase = phase
                if callable(attack):
                    attack(phase)
                while time.monotonic() - phase.started < args.phase:
                    time.sleep(0.05)
                camera.phase = None
                phase.ended = time.monotonic()
                time.sleep(2.0)  # the phase's last frames are answered, its heap trimmed
                phase.rss_peak, phase.rss_after = watch.peak, rss_mb(process.pid)
                phase.anon_after = anon_mb(process.pid)
                phases.append(phase)
                print(json.dumps(phase.summary(fresh)), flush=True)

            def huge_depth(phase: Phase) -> None:
                time.sleep(2.0)
                sent = time.monotonic()
                # A whole frame: the huge depth and a colour image of the same sequence,
                # which is what a pairing pipeline decodes (a lone half is only held).
                stamp = time.time()
                forger.publish(DepthImage(camera="front", stamp=stamp, sequence=7, data=huge))
                forger.publish(
                    CompressedImage(
                        camera="front", stamp=stamp, sequence=7, format="png", data=camera.colour
                    )
                )
                # Counted (the status's rejections) once refused: the next good frame clears
                # the status's error line, so the count is what is waited for.
                while not rejections[0].get(REFUSED) and time.monotonic() - sent < args.phase - 3:
                    time.sleep(0.01)
                counted = rejections[0].get(REFUSED)
                phase.extra["counted_refused_within_s"] = (
                    round(time.monotonic() - sent, 2) if counted else None
                )

            def unpaired(phase: Phase) -> None:
                started = time.monotonic()
                for sequence in range(args.halves, 0, -1):
                    payload = template.replace(b'"sequence":0', b'"sequence":%d' % sequence, 1)
                    forger.put_raw(DEPTH_KEY, payload, Delivery.RELIABLE)
                phase.extra["flood_s"] = round(time.monotonic() - started, 1)
                phase.extra["half_kb"] = len(half) // 1024

            run(Phase("reference"))
            run(Phase("huge depth"), huge_depth)
            run(Phase("unpaired"), unpaired)
            time.sleep(1.5)  # one more heartbeat for the counts
            counted = re.search(r"unpaired halves dropped (\d+)", last_detail[0])
            phases[-1].extra["halves_counted_dropped"] = int(counted[1]) if counted else None
            camera.stop.set()
            watch.stop.set()
    summary = {
        "phases": [p.summary(fresh) for p in phases],
        "load_average": os.getloadavg(),
        "cpus": os.cpu_count(),
    }
    print(json.dumps(summary, indent=1))


if __name__ == "__main__":
    main()
