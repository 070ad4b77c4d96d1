"""RGB-D perception (no markers) against the physics sim's ground truth, on colour + depth
frames rendered by its tripod camera (needs Vulkan: scripts/install-vulkan.sh), beside the
ArUco pipeline's speed in the same run.

For each seeded episode the expert's moves are replayed by placing each block on its goal
(a few millimetres off, as a real placement lands) and letting physics settle; every state
is rendered (colour, and depth through the D400-like sensor model) and perceived. Printed:

* pose error of the objects seen in the frame (median, p95; target median <= 5 mm) and the
  yaw error of the tops seen whole (target median <= 3 degrees);
* the false "filled" rate: goals perception calls filled that the sim's rule does not (and
  the missed ones);
* frames/s on one core at 640 x 480 (PNG decode of colour and depth, plane, segmentation,
  objects, tracking, Scene; target >= 15) beside the ArUco pipeline on its own rendered
  frames (``tests/perception/frames``), measured in the same run.

    nice .venv/bin/python bench/bench_rgbd.py --episodes 10
    nice .venv/bin/python bench/bench_rgbd.py --episodes 10 --depth-noise 2 \
        --camera-offset 0.01 --camera-tilt 1
    # the old identity, with the layout's starts 10 cm off where the blocks stand
    nice .venv/bin/python bench/bench_rgbd.py --episodes 10 --identity prior --start-off 0.1

``--identity appearance`` (the default, as the service's) gives perception no starting
position: there the pose error is to the nearest true object (objects that look alike are
interchangeable) and ``on another body`` counts ids posed on another object than their own.
The closed loop takes the same choice as ``manigraph up --scene-source rgbd --rgbd-identity
appearance|prior`` (docs/perception.md).
"""

from __future__ import annotations

import argparse
import contextlib
import json
import os
import time
from pathlib import Path
from typing import Any

import cv2
import msgspec
import numpy as np
import sapien

from manigraph_perception.calibration_file import Calibration
from manigraph_perception.pipeline import BadFrame
from manigraph_perception.pipelines.aruco.pipeline import Perception
from manigraph_perception.pipelines.rgbd.frames import decode_depth
from manigraph_perception.pipelines.rgbd.identity import IdentityMode
from manigraph_perception.pipelines.rgbd.pipeline import RgbdPerception
from manigraph_shared.acceptance import admits
from manigraph_shared.markers import sim_marker_map
from manigraph_shared.messages import EpisodeRequest, TaskLayout, Vector3
from manigraph_sim.physics.backend import PhysicsBackend
from manigraph_sim.physics.camera import CameraConfig, ideal_calibration
from manigraph_sim.physics.depth_noise import DepthNoise

#: The sim's goal tolerance (``--goal-tolerance``, default).
GOAL_TOLERANCE = 0.02
ARUCO_FRAMES = Path(__file__).resolve().parents[1] / "tests" / "perception" / "frames"


def _yaw(quaternion: np.ndarray) -> float:
    x, y, z, w = quaternion
    return float(np.arctan2(2 * (w * z + x * y), 1 - 2 * (y * y + z * z)))


def occupied_goals(layout: TaskLayout, world: Any) -> set[str]:
    """The sim's rule on the true poses: a block it accepts within 2 cm of a goal fills it."""
    truth = {o.id: np.asarray(world.pose(o.id)[0]) for o in layout.objects}
    return {
        goal.id
        for goal in layout.goals
        if any(
            o.category.value == goal.category.value
            and admits(goal.accepts, o.id, o.size.as_tuple(), o.attributes)
            and np.linalg.norm(truth[o.id] - np.array(goal.position.as_tuple())) <= GOAL_TOLERANCE
            for o in layout.objects
        )
    }


def _starts_off(layout: TaskLayout, distance: float, rng: np.random.Generator) -> TaskLayout:
    """``layout`` with each object's start moved ``distance`` in a random direction."""
    if distance == 0:
        return layout
    objects = []
    for o in layout.objects:
        angle = rng.uniform(0, 2 * np.pi)
        moved = Vector3(
            x=o.position.x + distance * np.cos(angle),
            y=o.position.y + distance * np.sin(angle),
            z=o.position.z,
        )
        objects.append(msgspec.structs.replace(o, position=moved))
    return msgspec.structs.replace(layout, objects=objects)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--episodes", type=int, default=10)
    parser.add_argument("--task", default="stack")
    parser.add_argument("--blocks", type=int, default=4)
    parser.add_argument("--offset", type=float, default=0.008, help="placement error, m")
    parser.add_argument("--depth-noise", type=float, default=1.0, help="times a D400's")
    parser.add_argument("--camera-offset", type=float, default=0.0, help="metres")
    parser.add_argument("--camera-tilt", type=float, default=0.0, help="degrees")
    parser.add_argument("--seed", type=int, default=100, help="first episode seed")
    parser.add_argument(
        "--identity", choices=[m.value for m in IdentityMode], default=IdentityMode.APPEARANCE
    )
    parser.add_argument(
        "--start-off", type=float, default=0.0, help="move the layout's starts this far, m"
    )
    args = parser.parse_args()
    identity = IdentityMode(args.identity)
    cv2.setNumThreads(1)

    config = CameraConfig(
        format="png",
        depth=DepthNoise(scale=args.depth_noise),
        markers=False,
        pose_error=(args.camera_offset, args.camera_tilt),
    )
    k, base_T_camera = ideal_calibration(CameraConfig())  # the nominal calibration
    calibration = Calibration(k, base_T_camera=base_T_camera)
    backend = PhysicsBackend(camera=config)
    rng = np.random.default_rng(0)

    errors_mm: list[float] = []
    yaw_deg: list[float] = []
    false_filled = empty_goals = missed = full_goals = bad_frames = withheld = swapped = 0
    frames: list[tuple[bytes, bytes]] = []
    layouts: list[TaskLayout] = []
    for episode in range(args.episodes):
        seed = args.seed + episode
        request = EpisodeRequest(
            episode_id=f"bench-{seed}", task=args.task, blocks=args.blocks, seed=seed
        )
        backend.reset(request, time.time())
        perception = RgbdPerception(calibration, identity=identity)
        layout = backend.layout_message(time.time())
        assert layout is not None and backend.world is not None
        perception.set_layout(_starts_off(layout, args.start_off, rng))
        layouts.append(layout)
        world = backend.world
        goals = sorted(layout.goals, key=lambda g: g.position.z)
        bodies = sorted(
            (o for o in layout.objects if o.category == "block"),
            key=lambda o: -world.pose(o.id)[0][2],
        )
        for step in range(len(goals) + 1):
            if step > 0:  # the expert's next move: a block onto the lowest open goal
                goal, body = goals[step - 1], bodies[(step - 1) % len(bodies)]
                if goal.category.value != "block":
                    continue
                off = rng.uniform(-args.offset, args.offset, 2)
                target = [goal.position.x + off[0], goal.position.y + off[1], goal.position.z]
                world.entities[body.id].set_pose(sapien.Pose(target))
                world.step(60)
            image, _ = backend.camera_frame(time.time())  # type: ignore[misc]
            depth_message = backend.camera_depth()
            assert depth_message is not None
            frames.append((image.data, depth_message.data))
            bgr = cv2.imdecode(np.frombuffer(image.data, np.uint8), cv2.IMREAD_COLOR)
            depth = decode_depth(depth_message.data)
            assert depth is not None
            try:
                scene, result = perception.process(bgr, depth, time.time(), time.time())
            except BadFrame:
                bad_frames += 1
                continue
            if scene is None:  # appearance: not every object found yet
                withheld += 1
                continue
            positions = {o.id: np.array(o.position.as_tuple()) for o in scene.objects}
            truth = {o.id: world.pose(o.id) for o in layout.objects}
            for object_id, detection in result.matches.items():
                centre, quaternion = truth[object_id]
                if identity is IdentityMode.APPEARANCE:
                    nearest = min(
                        truth,
                        key=lambda i: float(np.linalg.norm(positions[object_id] - truth[i][0])),
                    )
                    swapped += nearest != object_id
                    centre, quaternion = truth[nearest]
                errors_mm.append(float(np.linalg.norm(positions[object_id] - centre)) * 1000)
                if not detection.covered:
                    error = np.rad2deg(detection.yaw - _yaw(quaternion))
                    yaw_deg.append(abs((error + 45) % 90 - 45))
            occupied = occupied_goals(layout, world)
            for goal_state in scene.goals:
                if goal_state.id in occupied:
                    full_goals += 1
                    missed += not goal_state.filled
                else:
                    empty_goals += 1
                    false_filled += goal_state.filled
    errors = np.array(errors_mm)
    print(
        f"{len(frames)} frames, {args.episodes} episodes of {args.task} {args.blocks} (seeds "
        f"{args.seed}-{args.seed + args.episodes - 1}); depth noise x{args.depth_noise}, camera "
        f"off by {args.camera_offset} m / {args.camera_tilt} deg; {bad_frames} bad frames"
    )
    print(
        f"identity {identity.value}, layout starts {args.start_off} m off: {withheld} frames "
        f"without a Scene (objects not found yet), {swapped} ids on another body"
    )
    print(
        f"pose error, {len(errors)} objects seen: median {np.median(errors):.2f} mm, "
        f"p95 {np.percentile(errors, 95):.2f} mm, max {errors.max():.2f} mm (target median <= 5)"
    )
    print(
        f"yaw error, {len(yaw_deg)} tops seen whole: median {np.median(yaw_deg):.2f} deg, "
        f"p95 {np.percentile(yaw_deg, 95):.2f} deg (target median <= 3)"
    )
    print(
        f"false filled: {false_filled}/{empty_goals} empty goals = "
        f"{false_filled / max(empty_goals, 1):.4f}; missed: {missed}/{full_goals} filled goals"
    )

    # Speed on one core, the RGB-D pipeline on its frames and the ArUco pipeline on its own.
    os.sched_setaffinity(0, {sorted(os.sched_getaffinity(0))[0]})
    cv2.setNumThreads(1)
    perception = RgbdPerception(calibration, identity=identity)
    perception.set_layout(layouts[-1])
    t = time.perf_counter()
    for colour, depth_png in frames:
        bgr = cv2.imdecode(np.frombuffer(colour, np.uint8), cv2.IMREAD_COLOR)
        depth = decode_depth(depth_png)
        assert depth is not None
        with contextlib.suppress(BadFrame):
            perception.process(bgr, depth, time.time(), time.time())
    rgbd_fps = len(frames) / (time.perf_counter() - t)
    aruco_frames = sorted(ARUCO_FRAMES.glob("stack4-*.png"))
    aruco = Perception(sim_marker_map(), calibration)
    aruco_layout = TaskLayout.from_builtins(
        json.loads(aruco_frames[0].with_suffix(".json").read_text())["layout"]
    )
    aruco.set_layout(aruco_layout)
    encoded = [p.read_bytes() for p in aruco_frames]
    t = time.perf_counter()
    for _ in range(max(1, len(frames) // len(encoded))):
        for data in encoded:
            grey = cv2.imdecode(np.frombuffer(data, np.uint8), cv2.IMREAD_GRAYSCALE)
            aruco.process(grey, time.time(), time.time())
    aruco_fps = max(1, len(frames) // len(encoded)) * len(encoded) / (time.perf_counter() - t)
    print(
        f"frames/s on one core at 640 x 480: RGB-D pipeline {rgbd_fps:.1f} (target >= 15), "
        f"ArUco pipeline {aruco_fps:.1f} ({len(encoded)} rendered marker frames), same run"
    )
    print(f"load average: {' '.join(f'{v:.1f}' for v in os.getloadavg())}")
    print(
        json.dumps(
            {
                "pose_median_mm": round(float(np.median(errors)), 2),
                "pose_p95_mm": round(float(np.percentile(errors, 95)), 2),
                "yaw_median_deg": round(float(np.median(yaw_deg)), 2),
                "false_filled_rate": round(false_filled / max(empty_goals, 1), 4),
                "missed_filled": missed,
                "rgbd_fps": round(rgbd_fps, 1),
                "aruco_fps": round(aruco_fps, 1),
            }
        )
    )


if __name__ == "__main__":
    main()
