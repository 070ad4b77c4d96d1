"""A robot log written with manigraph's own writer: what the physics sim and a camera record
(joint states of the Panda, camera frames and intrinsics), with scenes, decisions,
explanations and episode events, one chunk flushed every few messages so a cut file keeps
most of them."""

from __future__ import annotations

import io
import math
import random
from pathlib import Path

import pytest
from PIL import Image

from manigraph_shared.mcap_log import McapLogWriter
from manigraph_shared.messages import (
    Action,
    CameraInfo,
    CompressedImage,
    EpisodeEvent,
    EpisodePhase,
    ExplainedEdge,
    ExplainedNode,
    Explanation,
    GoalCategory,
    ImageFormat,
    JointState,
    Message,
    ObjectCategory,
    Quaternion,
    Scene,
    SceneGoal,
    SceneObject,
    ServiceState,
    ServiceStatus,
    Vector3,
)
from manigraph_shared.panda import ARM_JOINTS

T0 = 1_767_000_000.0
STEPS = 6
JOINT_STATES_PER_STEP = 10


def jpeg(seed: int) -> bytes:
    image = Image.new("RGB", (64, 48), ((seed * 40) % 256, 120, 200))
    buffer = io.BytesIO()
    image.save(buffer, format="JPEG")
    return buffer.getvalue()


def scene(sequence: int, stamp: float, rng: random.Random) -> Scene:
    angle = rng.uniform(-math.pi, math.pi)
    turn = Quaternion(x=0.0, y=0.0, z=math.sin(angle / 2), w=math.cos(angle / 2))
    blocks = [
        SceneObject(
            id=f"block_{i}",
            category=ObjectCategory.BLOCK,
            position=Vector3(x=0.4 + 0.05 * i, y=rng.uniform(-0.2, 0.2), z=0.02),
            orientation=turn,
            size=Vector3(x=0.04, y=0.04, z=0.04),
            filled=i < sequence,
        )
        for i in range(3)
    ]
    goals = [
        SceneGoal(
            id=f"goal_{i}",
            category=GoalCategory.BLOCK,
            position=Vector3(x=0.5, y=0.1, z=0.02 + 0.04 * i),
            filled=i < sequence,
        )
        for i in range(3)
    ]
    return Scene(episode_id="ep", stamp=stamp, sequence=sequence, objects=blocks, goals=goals)


def write_robot_log(path: Path, steps: int = STEPS, seed: int = 7) -> None:
    rng = random.Random(seed)
    writer = McapLogWriter(path, flush_interval=3600.0)
    written = 0

    def put(message: Message, stamp: float) -> None:
        nonlocal written
        # The log time is when the recorder received it: a little after the stamp.
        writer.write(message.key_for(), message.encode(), round((stamp + 0.003) * 1e9))
        written += 1
        if written % 8 == 0:
            writer.flush()

    put(
        EpisodeEvent(
            episode_id="ep",
            phase=EpisodePhase.START,
            task="stack",
            seed=seed,
            goals_total=3,
            goals_filled=0,
            stamp=T0,
        ),
        T0,
    )
    put(
        CameraInfo(
            camera="table",
            stamp=T0,
            width=64,
            height=48,
            camera_matrix=[60.0, 0, 32.0, 0, 60.0, 24.0, 0, 0, 1.0],
            distortion=[0.01, -0.02, 0.0, 0.0, 0.003],
        ),
        T0,
    )
    for step in range(steps):
        t = T0 + 1.0 + step
        put(scene(step, t, rng), t)
        for k in range(JOINT_STATES_PER_STEP):
            stamp = t + 0.01 * (k + 1)
            put(
                JointState(
                    joint_names=list(ARM_JOINTS),
                    positions=[rng.uniform(-2.5, 2.5) for _ in ARM_JOINTS],
                    gripper_width=rng.uniform(0.0, 0.08),
                    stamp=stamp,
                ),
                stamp,
            )
        put(
            CompressedImage(
                camera="table",
                stamp=t + 0.2,
                sequence=step,
                format=ImageFormat.JPEG,
                data=jpeg(step),
            ),
            t + 0.2,
        )
        put(
            Action(
                decision_id=f"ep:{step}",
                episode_id="ep",
                scene_sequence=step,
                object_id=f"block_{step % 3}",
                goal_id=f"goal_{step % 3}",
                policy="expert",
                stamp=t + 0.3,
            ),
            t + 0.3,
        )
        put(
            Explanation(
                decision_id=f"ep:{step}",
                episode_id="ep",
                scene_sequence=step,
                policy="expert",
                object=f"block_{step % 3}",
                goal=f"goal_{step % 3}",
                edges=[ExplainedEdge(src=f"block_{step % 3}", dst=f"goal_{step % 3}", weight=0.9)],
                features={"category": 0.8},
                nodes=[
                    ExplainedNode(
                        id=f"block_{step % 3}",
                        category="block",
                        position=Vector3(x=0.4, y=0.0, z=0.02),
                    )
                ],
                sentence="the block goes on the goal below it",
                fidelity=0.7,
                seed=0,
                stamp=t + 0.4,
            ),
            t + 0.4,
        )
        put(ServiceStatus(service="sim", state=ServiceState.OK, stamp=t + 0.5), t + 0.5)
    put(
        EpisodeEvent(
            episode_id="ep",
            phase=EpisodePhase.END,
            task="stack",
            seed=seed,
            goals_total=3,
            goals_filled=3,
            steps=steps,
            success=True,
            reason="all goals filled",
            stamp=T0 + steps + 2,
        ),
        T0 + steps + 2,
    )
    writer.close()


@pytest.fixture(scope="module")
def robot_log(tmp_path_factory: pytest.TempPathFactory) -> Path:
    path = tmp_path_factory.mktemp("logs") / "robot.mcap"
    write_robot_log(path)
    return path
