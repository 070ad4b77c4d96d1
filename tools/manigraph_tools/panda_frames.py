"""The Panda's link frames from a ``JointState``, as Foxglove ``FrameTransforms``.

The chain is the one of the Panda URDF the physics sim loads (``panda_v2.urdf`` in the
mani-skill package): each joint's fixed origin (translation, roll-pitch-yaw) followed by its
rotation about z (revolute) or its slide along y (fingers). The values are copied here
because the tools must not import the skills service (Pinocchio) nor mani-skill; the unit
test checks the chain against the ready pose documented in ``manigraph_shared.panda``.

The robot base ``panda_link0`` stands at the origin of the scene frame (the physics world
loads the Panda with an identity root pose; the table top is z = 0).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from foxglove.messages import FrameTransform, FrameTransforms, Quaternion, Timestamp, Vector3

from manigraph_shared.messages import JointState
from manigraph_shared.panda import ARM_JOINTS

BASE_FRAME = "panda_link0"
TCP_FRAME = "panda_hand_tcp"

Quat = tuple[float, float, float, float]  # x, y, z, w
Vec = tuple[float, float, float]


@dataclass(frozen=True)
class Link:
    """A URDF joint: ``child`` sits at ``xyz``/``rpy`` in ``parent``, then moves by
    ``joint`` (revolute about z, prismatic along ``slide``, or fixed when ``joint`` is None)."""

    parent: str
    child: str
    xyz: Vec
    rpy: Vec = (0.0, 0.0, 0.0)
    joint: str | None = None
    slide: float = 0.0  # prismatic fingers: +1 along y, -1 against it


HALF_PI = math.pi / 2
CHAIN = (
    Link("panda_link0", "panda_link1", (0.0, 0.0, 0.333), joint="panda_joint1"),
    Link("panda_link1", "panda_link2", (0.0, 0.0, 0.0), (-HALF_PI, 0, 0), "panda_joint2"),
    Link("panda_link2", "panda_link3", (0.0, -0.316, 0.0), (HALF_PI, 0, 0), "panda_joint3"),
    Link("panda_link3", "panda_link4", (0.0825, 0.0, 0.0), (HALF_PI, 0, 0), "panda_joint4"),
    Link("panda_link4", "panda_link5", (-0.0825, 0.384, 0.0), (-HALF_PI, 0, 0), "panda_joint5"),
    Link("panda_link5", "panda_link6", (0.0, 0.0, 0.0), (HALF_PI, 0, 0), "panda_joint6"),
    Link("panda_link6", "panda_link7", (0.088, 0.0, 0.0), (HALF_PI, 0, 0), "panda_joint7"),
    Link("panda_link7", "panda_link8", (0.0, 0.0, 0.107)),
    Link("panda_link8", "panda_hand", (0.0, 0.0, 0.0), (0.0, 0.0, -math.pi / 4)),
    Link("panda_hand", TCP_FRAME, (0.0, 0.0, 0.1034)),
    Link("panda_hand", "panda_leftfinger", (0.0, 0.0, 0.0584), slide=1.0),
    Link("panda_hand", "panda_rightfinger", (0.0, 0.0, 0.0584), slide=-1.0),
)


def quat_multiply(a: Quat, b: Quat) -> Quat:
    ax, ay, az, aw = a
    bx, by, bz, bw = b
    return (
        aw * bx + ax * bw + ay * bz - az * by,
        aw * by - ax * bz + ay * bw + az * bx,
        aw * bz + ax * by - ay * bx + az * bw,
        aw * bw - ax * bx - ay * by - az * bz,
    )


def quat_from_rpy(roll: float, pitch: float, yaw: float) -> Quat:
    """URDF convention: rotate about x by roll, then y by pitch, then z by yaw (fixed axes)."""
    rx = (math.sin(roll / 2), 0.0, 0.0, math.cos(roll / 2))
    ry = (0.0, math.sin(pitch / 2), 0.0, math.cos(pitch / 2))
    rz = (0.0, 0.0, math.sin(yaw / 2), math.cos(yaw / 2))
    return quat_multiply(rz, quat_multiply(ry, rx))


def rotate(q: Quat, v: Vec) -> Vec:
    x, y, z, _ = quat_multiply(quat_multiply(q, (*v, 0.0)), (-q[0], -q[1], -q[2], q[3]))
    return (x, y, z)


def link_poses(state: JointState) -> dict[str, tuple[Vec, Quat]]:
    """Each link's pose relative to its parent (translation, rotation), in ``CHAIN`` order.

    Arm joints missing from ``state`` are taken at 0; each finger is half the gripper width
    from the hand's centre.
    """
    angles = dict(zip(state.joint_names, state.positions, strict=True))
    poses: dict[str, tuple[Vec, Quat]] = {}
    for link in CHAIN:
        rotation = quat_from_rpy(*link.rpy)
        translation = link.xyz
        if link.joint is not None:
            angle = angles.get(link.joint, 0.0)
            rotation = quat_multiply(rotation, (0.0, 0.0, math.sin(angle / 2), math.cos(angle / 2)))
        if link.slide:
            offset = rotate(rotation, (0.0, link.slide * state.gripper_width / 2, 0.0))
            translation = (
                translation[0] + offset[0],
                translation[1] + offset[1],
                translation[2] + offset[2],
            )
        poses[link.child] = (translation, rotation)
    return poses


def world_poses(state: JointState) -> dict[str, tuple[Vec, Quat]]:
    """Each link's pose in the base frame (forward kinematics), base included."""
    parents = {link.child: link.parent for link in CHAIN}
    local = link_poses(state)
    world: dict[str, tuple[Vec, Quat]] = {BASE_FRAME: ((0.0, 0.0, 0.0), (0.0, 0.0, 0.0, 1.0))}
    for child, (translation, rotation) in local.items():
        parent_position, parent_rotation = world[parents[child]]
        moved = rotate(parent_rotation, translation)
        world[child] = (
            (
                parent_position[0] + moved[0],
                parent_position[1] + moved[1],
                parent_position[2] + moved[2],
            ),
            quat_multiply(parent_rotation, rotation),
        )
    return world


def _transform(stamp: float, parent: str, child: str, pose: tuple[Vec, Quat]) -> FrameTransform:
    (x, y, z), (qx, qy, qz, qw) = pose
    return FrameTransform(
        timestamp=Timestamp.from_epoch_secs(stamp),
        parent_frame_id=parent,
        child_frame_id=child,
        translation=Vector3(x=x, y=y, z=z),
        rotation=Quaternion(x=qx, y=qy, z=qz, w=qw),
    )


def base_transforms(scene_frame: str, stamp: float) -> FrameTransforms:
    """The robot base in the scene frame: all that is known without joint angles."""
    identity = ((0.0, 0.0, 0.0), (0.0, 0.0, 0.0, 1.0))
    return FrameTransforms(transforms=[_transform(stamp, scene_frame, BASE_FRAME, identity)])


def robot_transforms(state: JointState, scene_frame: str) -> FrameTransforms:
    """The base in the scene frame and one transform per link of the chain."""
    parents = {link.child: link.parent for link in CHAIN}
    identity = ((0.0, 0.0, 0.0), (0.0, 0.0, 0.0, 1.0))
    transforms = [_transform(state.stamp, scene_frame, BASE_FRAME, identity)]
    transforms += [
        _transform(state.stamp, parents[child], child, pose)
        for child, pose in link_poses(state).items()
    ]
    return FrameTransforms(transforms=transforms)


def is_panda(state: JointState) -> bool:
    """Whether ``state`` names the Panda's arm joints (another robot's are not this chain)."""
    return set(state.joint_names) <= set(ARM_JOINTS) and bool(state.joint_names)
