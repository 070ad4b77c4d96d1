"""Regenerate the rendered frames the perception tests read (needs Vulkan):

    .venv/bin/python tests/perception/make_frames.py

Each frame is a PNG from the sim's tripod camera plus a JSON with the episode's layout (the
``TaskLayout`` the sim publishes) and every body's true pose (centre, quaternion x y z w).
"""

from __future__ import annotations

import json
import time
from pathlib import Path

import cv2
import numpy as np
import sapien

from manigraph_shared.messages import EpisodeRequest
from manigraph_sim.physics.backend import PhysicsBackend
from manigraph_sim.physics.camera import CameraConfig

HERE = Path(__file__).parent / "frames"


def save(name: str, backend: PhysicsBackend) -> None:
    assert backend.world is not None and backend.camera is not None
    rgb = backend.camera.render()
    cv2.imwrite(str(HERE / f"{name}.png"), cv2.cvtColor(rgb, cv2.COLOR_RGB2BGR))
    layout = backend.layout_message(time.time())
    assert layout is not None
    truth = {
        body: [p.tolist() for p in backend.world.pose(body)] for body in backend.world.entities
    }
    record = {"layout": json.loads(layout.to_json()), "truth": truth}
    (HERE / f"{name}.json").write_text(json.dumps(record, indent=1))


def move(backend: PhysicsBackend, body: str, position: list[float]) -> None:
    assert backend.world is not None
    backend.world.entities[body].set_pose(sapien.Pose(position))


def main() -> None:
    HERE.mkdir(exist_ok=True)
    backend = PhysicsBackend(camera=CameraConfig())
    backend.reset(EpisodeRequest(episode_id="stack-0", task="stack", blocks=4, seed=0), 1.0)
    save("stack4-start", backend)
    # The top block put on the first goal: block_2 is now the top of the start stack.
    layout = backend.layout_message(1.0)
    assert layout is not None
    goal = layout.goals[0].position
    move(backend, "block_3", [goal.x, goal.y, goal.z])
    save("stack4-one-placed", backend)
    backend.reset(EpisodeRequest(episode_id="pack-0", task="box-pack", blocks=3, seed=0), 1.0)
    save("boxpack3-start", backend)
    blank = np.full((480, 640, 3), 180, np.uint8)
    cv2.imwrite(str(HERE / "blank.png"), blank)  # the stack's layout, nothing seen
    (HERE / "blank.json").write_text((HERE / "stack4-start.json").read_text())


if __name__ == "__main__":
    main()
