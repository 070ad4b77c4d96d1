"""Time of `manigraph export --format ros2` on a ~100 MB log (target: at most 30 s).

The log is what a physics run with its camera records, written with manigraph's own writer:
per simulated second 10 camera frames (640 x 480 JPEG), 50 Panda joint states and 10 scenes of
6 blocks, with a decision and an episode's events now and then, until the file holds
``--megabytes``. Only the export is timed (reading the log, converting, writing the bag).
Ends with one JSON line.
"""

from __future__ import annotations

import argparse
import io
import json
import math
import os
import random
import sys
import tempfile
import time
from pathlib import Path

from PIL import Image

from manigraph_shared.mcap_log import McapLogWriter
from manigraph_shared.messages import (
    Action,
    CameraInfo,
    CompressedImage,
    EpisodeEvent,
    EpisodePhase,
    GoalCategory,
    ImageFormat,
    JointState,
    ObjectCategory,
    Scene,
    SceneGoal,
    SceneObject,
    Vector3,
)
from manigraph_shared.panda import ARM_JOINTS
from manigraph_tools.interop.ros2_bag import export_ros2

T0 = 1_767_000_000.0


def frames(count: int, rng: random.Random) -> list[bytes]:
    """Camera-like JPEGs: smooth shading plus noise, ~60-100 kB each."""
    out = []
    for k in range(count):
        image = Image.radial_gradient("L").resize((640, 480)).convert("RGB")
        noise = Image.effect_noise((640, 480), 40 + 5 * k).convert("RGB")
        blended = Image.blend(image, noise, 0.35)
        buffer = io.BytesIO()
        blended.save(buffer, format="JPEG", quality=85)
        out.append(buffer.getvalue())
    rng.shuffle(out)
    return out


def scene(sequence: int, stamp: float, rng: random.Random) -> Scene:
    return Scene(
        episode_id="bench",
        stamp=stamp,
        sequence=sequence,
        objects=[
            SceneObject(
                id=f"block_{i}",
                category=ObjectCategory.BLOCK,
                position=Vector3(x=0.4 + 0.01 * i, y=rng.uniform(-0.2, 0.2), z=0.02),
                size=Vector3(x=0.04, y=0.04, z=0.04),
            )
            for i in range(6)
        ],
        goals=[
            SceneGoal(
                id=f"goal_{i}",
                category=GoalCategory.BLOCK,
                position=Vector3(x=0.5, y=0.1, z=0.02 + 0.04 * i),
            )
            for i in range(6)
        ],
    )


def write_log(path: Path, megabytes: float) -> int:
    rng = random.Random(0)
    images = frames(8, rng)
    writer = McapLogWriter(path)
    written, step = 0, 0

    def put(message: object, stamp: float) -> None:
        nonlocal written
        assert hasattr(message, "encode") and hasattr(message, "key_for")
        writer.write(message.key_for(), message.encode(), round((stamp + 0.002) * 1e9))
        written += 1

    put(
        CameraInfo(
            camera="front",
            stamp=T0,
            width=640,
            height=480,
            camera_matrix=[415.7, 0, 320.0, 0, 415.7, 240.0, 0, 0, 1.0],
        ),
        T0,
    )
    put(
        EpisodeEvent(
            episode_id="bench",
            phase=EpisodePhase.START,
            task="stack",
            seed=0,
            goals_total=6,
            goals_filled=0,
            stamp=T0,
        ),
        T0,
    )
    while writer.bytes_written < megabytes * 1e6:
        t = T0 + step / 50
        put(
            JointState(
                joint_names=list(ARM_JOINTS),
                positions=[math.sin(t + j) for j in range(7)],
                gripper_width=0.04,
                stamp=t,
            ),
            t,
        )
        if step % 5 == 0:
            put(scene(step // 5, t, rng), t)
            put(
                CompressedImage(
                    camera="front",
                    stamp=t,
                    sequence=step // 5,
                    format=ImageFormat.JPEG,
                    data=images[(step // 5) % len(images)],
                ),
                t,
            )
        if step % 100 == 0:
            put(
                Action(
                    decision_id=f"bench:{step}",
                    episode_id="bench",
                    scene_sequence=step // 5,
                    object_id="block_0",
                    goal_id="goal_0",
                    policy="expert",
                    stamp=t,
                ),
                t,
            )
        step += 1
    writer.close()
    return written


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--megabytes", type=float, default=100.0, help="log size to build")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        log, bag = Path(tmp) / "run.mcap", Path(tmp) / "bag"
        started = time.perf_counter()
        messages = write_log(log, args.megabytes)
        built = time.perf_counter() - started
        log_mb = log.stat().st_size / 1e6
        print(f"built {log_mb:.1f} MB, {messages} messages in {built:.1f} s", file=sys.stderr)
        started = time.perf_counter()
        summary = export_ros2(log, bag, io.StringIO())
        seconds = time.perf_counter() - started
        bag_mb = sum(p.stat().st_size for p in bag.iterdir()) / 1e6
    print(f"exported in {seconds:.1f} s ({log_mb / seconds:.1f} MB/s)")
    result = {
        "bench": "ros2_export",
        "log_mb": round(log_mb, 1),
        "messages": messages,
        "messages_written": summary["messages_written"],
        "bag_mb": round(bag_mb, 1),
        "seconds": round(seconds, 2),
        "target_seconds": 30,
        "load_1min": round(os.getloadavg()[0], 2),
        "cpus": os.cpu_count(),
    }
    print(json.dumps(result))
    return 0


if __name__ == "__main__":
    sys.exit(main())
