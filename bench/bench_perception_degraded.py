"""Perception on degraded images, offline: frames of seeded episodes are rendered once (clean,
before encoding) with the sim's ground truth, then degraded as the sim camera would (Gaussian
noise, motion blur, JPEG) and perceived, as often as wanted, with parts of the pipeline
switched off. This is how the pipeline was tuned for blur, on seeds 100-119 (the closed-loop
and ``bench_perception.py`` figures are on seeds 0-19).

    nice .venv/bin/python bench/bench_perception_degraded.py render --seeds 100-119 \\
        -o bench/results/frames-100-119.pkl
    nice .venv/bin/python bench/bench_perception_degraded.py evaluate \\
        bench/results/frames-100-119.pkl --noise 5 --blur 5 [--no-deblur] [--no-rest]

Printed: object observations (objects with a detected marker), their pose error (median,
p95, max; along the viewing ray and across it), goal ``filled`` against the sim's rule, and
frames/s. As in ``bench_perception.py`` the blocks are put on their goals by hand (no planner
actions, no gripper), so a block never seen after it moved is believed where it started.
"""

from __future__ import annotations

import argparse
import pickle
import time
from pathlib import Path

import cv2
import numpy as np

from manigraph_perception.calibration_file import Calibration
from manigraph_perception.pipelines.aruco.pipeline import Perception
from manigraph_perception.world_belief import WorldConfig
from manigraph_shared.markers import sim_marker_map
from manigraph_shared.messages import EpisodeRequest, TaskLayout
from manigraph_sim.physics.camera import CameraConfig, degrade, encode_image


def render(seeds: range, task: str, blocks: int, out: Path) -> None:
    import sapien

    from manigraph_sim.physics.backend import PhysicsBackend

    backend = PhysicsBackend(camera=CameraConfig())
    rng = np.random.default_rng(0)
    episodes = []
    for seed in seeds:
        request = EpisodeRequest(episode_id=f"degraded-{seed}", task=task, blocks=blocks, seed=seed)
        backend.reset(request, time.time())
        layout = backend.layout_message(time.time())
        world, camera = backend.world, backend.camera
        assert layout is not None and world is not None and camera is not None
        goals = sorted(layout.goals, key=lambda g: g.position.z)
        bodies = sorted(
            (o for o in layout.objects if o.category == "block"),
            key=lambda o: -world.pose(o.id)[0][2],
        )
        frames = []
        for step in range(len(goals) + 1):
            if step > 0:  # the expert's next move, up to 8 mm off the goal, settled
                goal, body = goals[step - 1], bodies[(step - 1) % len(bodies)]
                if goal.category.value != "block":
                    continue
                off = rng.uniform(-0.008, 0.008, 2)
                target = [goal.position.x + off[0], goal.position.y + off[1], goal.position.z]
                world.entities[body.id].set_pose(sapien.Pose(target))
                world.step(60)
            truth = {o.id: world.pose(o.id)[0] for o in layout.objects}
            frames.append(
                {
                    "rgb": camera.render(),
                    "truth": truth,
                    "occupied": backend.evaluation().filled_goals,
                }
            )
        episodes.append({"layout": layout.to_json(), "frames": frames})
        print(f"seed {seed}: {len(frames)} frames", flush=True)
    assert backend.camera is not None
    record = {
        "episodes": episodes,
        "k": backend.camera.camera_matrix(),
        "base_T_camera": backend.camera.base_T_camera(),
    }
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_bytes(pickle.dumps(record))


def evaluate(path: Path, noise: float, blur: int, deblur: bool, rest: bool) -> None:
    data = pickle.loads(path.read_bytes())
    calibration = Calibration(data["k"], base_T_camera=data["base_T_camera"])
    camera_at = data["base_T_camera"][:3, 3]
    config = CameraConfig(noise_sigma=noise, blur_pixels=blur)
    rng = np.random.default_rng(0)
    errors, along, across = [], [], []
    checks = correct = frames = 0
    seconds = 0.0
    for episode in data["episodes"]:
        layout = TaskLayout.decode(episode["layout"].encode())
        world = WorldConfig() if rest else WorldConfig(rest=None)
        perception = Perception(sim_marker_map(), calibration, world=world)
        if not deblur:
            perception.detector = perception.detector._replace(gauge=None)
        perception.set_layout(layout)
        for frame in episode["frames"]:
            image = encode_image(degrade(frame["rgb"], config, rng), config, 0.0, frames)
            t = time.perf_counter()
            scene, detections = perception.process_image(image, 0.0)
            seconds += time.perf_counter() - t
            frames += 1
            assert scene is not None and detections is not None
            seen = {m.object_id for m in detections.markers if m.object_id}
            for obj in scene.objects:
                if obj.id not in seen:
                    continue
                truth = frame["truth"][obj.id]
                error = np.array(obj.position.as_tuple()) - truth
                ray = (truth - camera_at) / np.linalg.norm(truth - camera_at)
                errors.append(np.linalg.norm(error) * 1000)
                along.append(abs(error @ ray) * 1000)
                across.append(np.linalg.norm(error - (error @ ray) * ray) * 1000)
            for goal in scene.goals:
                checks += 1
                correct += goal.filled == (goal.id in frame["occupied"])
    e = np.array(errors)
    print(
        f"noise {noise:g}, blur {blur} px, deblur {'on' if deblur else 'off'}, rest "
        f"{'on' if rest else 'off'}: {len(e)} observations in {frames} frames; pose error "
        f"median {np.median(e):.2f} mm, p95 {np.percentile(e, 95):.2f}, max {e.max():.1f} "
        f"(median along the ray {np.median(along):.2f}, across {np.median(across):.2f}); "
        f"filled {correct}/{checks} = {correct / checks:.3f}; {frames / seconds:.1f} frames/s"
    )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    commands = parser.add_subparsers(dest="command", required=True)
    make = commands.add_parser("render", help="render clean frames with ground truth")
    make.add_argument("--seeds", default="100-119", help="first-last")
    make.add_argument("--task", default="stack")
    make.add_argument("--blocks", type=int, default=4)
    make.add_argument("-o", "--output", type=Path, required=True)
    score = commands.add_parser("evaluate", help="degrade and perceive rendered frames")
    score.add_argument("frames", type=Path)
    score.add_argument("--noise", type=float, default=0.0, help="Gaussian, grey levels")
    score.add_argument("--blur", type=int, default=0, help="horizontal motion blur, px")
    score.add_argument("--no-deblur", action="store_true", help="switch off the blur gauge")
    score.add_argument("--no-rest", action="store_true", help="blocks not rested on supports")
    args = parser.parse_args()
    cv2.setNumThreads(1)
    if args.command == "render":
        first, last = (int(v) for v in args.seeds.split("-"))
        render(range(first, last + 1), args.task, args.blocks, args.output)
    else:
        evaluate(args.frames, args.noise, args.blur, not args.no_deblur, not args.no_rest)


if __name__ == "__main__":
    main()
