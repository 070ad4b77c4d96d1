"""Cost of the Foxglove views per bus sample: a Scene's JSON decoded, turned into a
SceneUpdate (with a decision arrow) and encoded to protobuf, as the recorder and
``manigraph view`` do for every Scene; and a JointState into FrameTransforms.

Prints the median over repeated conversions, for scenes of 4 and 40 blocks.
"""

from __future__ import annotations

import argparse
import statistics
import time

from manigraph_shared.messages import (
    Action,
    GoalCategory,
    JointState,
    ObjectCategory,
    Scene,
    SceneGoal,
    SceneObject,
    Vector3,
)
from manigraph_shared.panda import ARM_JOINTS, HOME_Q
from manigraph_tools.foxglove_bridge import FoxgloveBridge


def scene(blocks: int) -> Scene:
    return Scene(
        episode_id="bench",
        stamp=time.time(),
        sequence=1,
        objects=[
            SceneObject(
                id=f"block_{i}",
                category=ObjectCategory.BLOCK,
                position=Vector3(x=0.3 + 0.01 * i, y=0.0, z=0.02 + 0.04 * i),
                size=Vector3(x=0.04, y=0.04, z=0.04),
            )
            for i in range(blocks)
        ],
        goals=[
            SceneGoal(
                id=f"goal_{i}",
                category=GoalCategory.BLOCK,
                position=Vector3(x=0.5, y=0.2, z=0.02 + 0.04 * i),
            )
            for i in range(blocks)
        ],
    )


def median_us(convert: object, key: str, payload: bytes, repeats: int) -> float:
    times = []
    for _ in range(repeats):
        start = time.perf_counter()
        for converted in convert(key, payload):  # type: ignore[operator]
            converted.message.encode()
        times.append(time.perf_counter() - start)
    return statistics.median(times) * 1e6


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--repeats", type=int, default=300)
    args = parser.parse_args()
    print("Foxglove conversion per sample (decode JSON + convert + protobuf encode), median")
    print(f"{'sample':>22} {'us':>8}")
    for blocks in (4, 40):
        bridge = FoxgloveBridge()
        bridge.on_message(
            Action(
                decision_id="bench:0",
                episode_id="bench",
                scene_sequence=1,
                object_id="block_0",
                goal_id="goal_1",
                policy="bench",
                stamp=time.time(),
            )
        )
        payload = scene(blocks).encode()
        us = median_us(bridge.convert, Scene.key, payload, args.repeats)
        print(f"{f'Scene, {blocks} blocks':>22} {us:>8.0f}")
    state = JointState(
        joint_names=list(ARM_JOINTS), positions=HOME_Q.tolist(), gripper_width=0.08, stamp=1.0
    )
    us = median_us(FoxgloveBridge().convert, JointState.key, state.encode(), args.repeats)
    print(f"{'JointState':>22} {us:>8.0f}")


if __name__ == "__main__":
    main()
