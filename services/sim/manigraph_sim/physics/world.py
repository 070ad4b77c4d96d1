"""A SAPIEN 3 tabletop: the Panda, the table and 4 cm blocks; physics only unless rendering.

The robot is the Panda URDF shipped with mani-skill, loaded without its visual meshes, so the
world runs on machines with no Vulkan device (only a video needs one). Its links ignore
gravity (as ManiSkill's Panda does: the real arm compensates gravity) and every joint follows
a PD drive towards a target.
The table top is the plane z = 0 in the robot base frame, where the task layouts stand.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import sapien
from sapien import physx

from manigraph_shared.errors import ConfigError
from manigraph_shared.panda import ARM_JOINTS, FINGER_OPEN, HOME_Q, panda_urdf_path
from manigraph_sim.geometric.world import Body

#: Where an episode starts: Franka's "ready" pose with the hand turned a quarter, TCP at
#: (0.31, 0, 0.49) m, high and close to the base so it clears every stack of a layout.
#: (The skills' motion model starts its plans from the same pose.)
TABLE_COLOUR = [0.62, 0.5, 0.38, 1.0]
#: Block colours when rendering (RGBA), cycled by block index.
BLOCK_COLOURS = [
    [0.85, 0.25, 0.2, 1.0],
    [0.2, 0.55, 0.85, 1.0],
    [0.95, 0.75, 0.2, 1.0],
    [0.3, 0.7, 0.35, 1.0],
    [0.6, 0.35, 0.75, 1.0],
    [0.95, 0.5, 0.15, 1.0],
]


@dataclass(frozen=True)
class PhysicsConfig:
    """Physical constants of the world; the defaults grasp 4 cm blocks reliably."""

    timestep: float = 1 / 200  # seconds per physics step
    drive_stiffness: float = 1000.0  # N m / rad (arm) and N / m (fingers)
    drive_damping: float = 100.0
    finger_friction: float = 2.0
    block_friction: float = 2.0
    table_friction: float = 1.0
    block_density: float = 1000.0  # kg / m^3: a 4 cm block weighs 64 g
    settle_time: float = 0.2  # seconds simulated after a motion so things come to rest

    def __post_init__(self) -> None:
        if not 1e-4 <= self.timestep <= 0.05:
            raise ConfigError("physics.timestep", "must be in [1e-4, 0.05] seconds")
        for name in ("drive_stiffness", "drive_damping", "block_density"):
            if getattr(self, name) <= 0:
                raise ConfigError(f"physics.{name}", "must be > 0")
        for name in ("finger_friction", "block_friction", "table_friction", "settle_time"):
            if getattr(self, name) < 0:
                raise ConfigError(f"physics.{name}", "must be >= 0")


class PhysicsWorld:
    """One episode's SAPIEN scene. Build a new one per episode: a fresh scene stepped with
    the same commands gives the same result (seeded determinism).

    With ``render=True`` the robot and blocks also get visual shapes (for a video camera);
    that needs a Vulkan device. ``on_step`` callbacks run after every physics step.
    """

    def __init__(
        self, bodies: list[Body], config: PhysicsConfig | None = None, render: bool = False
    ) -> None:
        self.config = config or PhysicsConfig()
        c = self.config
        self.render = render
        self.on_step: list[Callable[[], None]] = []
        self.scene = sapien.Scene() if render else sapien.Scene([physx.PhysxCpuSystem()])
        self.scene.set_timestep(c.timestep)
        self.sim_time = 0.0
        table_look = sapien.render.RenderMaterial(base_color=TABLE_COLOUR) if render else None
        self.scene.add_ground(
            0.0,
            render=render,
            material=physx.PhysxMaterial(*[c.table_friction] * 2, 0.0),
            render_material=table_look,
            render_half_size=[1.0, 1.0],
        )
        self.robot = self._load_panda()
        self.joints = self.robot.active_joints
        self.arm = [j for j in self.joints if j.name in ARM_JOINTS]
        self.fingers = [j for j in self.joints if j.name not in ARM_JOINTS]
        block_material = physx.PhysxMaterial(c.block_friction, c.block_friction, 0.0)
        self.blocks: dict[str, physx.PhysxRigidDynamicComponent] = {}
        self.entities: dict[str, sapien.Entity] = {}
        for index, body in enumerate(bodies):
            builder = self.scene.create_actor_builder()
            builder.add_box_collision(
                half_size=body.size / 2, material=block_material, density=c.block_density
            )
            if render:
                colour = BLOCK_COLOURS[index % len(BLOCK_COLOURS)]
                builder.add_box_visual(half_size=body.size / 2, material=colour)
            entity = builder.build(name=body.id)
            entity.set_pose(sapien.Pose(body.position))
            self.entities[body.id] = entity
        self.set_targets(HOME_Q, closed=False)
        self.robot.set_qpos(np.concatenate([HOME_Q, [FINGER_OPEN, FINGER_OPEN]]))
        self.gripper_closed = False
        self.step(round(c.settle_time / c.timestep))

    def _load_panda(self) -> physx.PhysxArticulation:
        c = self.config
        loader = self.scene.create_urdf_loader()
        builders, _, _ = loader.parse(str(panda_urdf_path()))
        (builder,) = builders
        if not self.render:
            for link in builder.link_builders:
                link.visual_records = []  # state only: no render device needed
        robot = builder.build(fix_root_link=True)
        finger_material = physx.PhysxMaterial(c.finger_friction, c.finger_friction, 0.0)
        for link in robot.links:
            link.disable_gravity = True
            if "finger" in link.name:
                for shape in link.collision_shapes:
                    shape.physical_material = finger_material
        for joint in robot.active_joints:
            joint.set_drive_properties(c.drive_stiffness, c.drive_damping)
        return robot

    # --- state ------------------------------------------------------------------------------
    @property
    def arm_q(self) -> np.ndarray:
        return np.asarray(self.robot.qpos[: len(self.arm)], dtype=float)

    @property
    def gripper_width(self) -> float:
        return float(np.clip(np.sum(self.robot.qpos[len(self.arm) :]), 0.0, 0.2))

    def pose(self, body_id: str) -> tuple[np.ndarray, np.ndarray]:
        """Centre (x, y, z) and orientation quaternion (x, y, z, w) of a block."""
        pose = self.entities[body_id].pose
        w, x, y, z = (float(v) for v in pose.q)  # SAPIEN stores (w, x, y, z)
        return np.asarray(pose.p, dtype=float), np.array([x, y, z, w])

    def tcp_position(self) -> np.ndarray:
        for link in self.robot.links:
            if link.name == "panda_hand_tcp":
                return np.asarray(link.entity_pose.p, dtype=float)
        raise ConfigError("panda_urdf", "no panda_hand_tcp link")

    # --- motion -----------------------------------------------------------------------------
    def set_targets(self, arm_q: np.ndarray, closed: bool) -> None:
        for joint, value in zip(self.arm, arm_q, strict=True):
            joint.set_drive_target(float(value))
        finger = 0.0 if closed else FINGER_OPEN
        for joint in self.fingers:
            joint.set_drive_target(finger)
        self.gripper_closed = closed

    def step(self, count: int = 1) -> None:
        for _ in range(count):
            self.scene.step()
            for callback in self.on_step:
                callback()
        self.sim_time += count * self.config.timestep

    def follow(
        self, times: np.ndarray, positions: np.ndarray, closed: list[bool], realtime: bool
    ) -> int:
        """Track the trajectory step by step (linear between points), then settle.
        Returns the number of physics steps taken."""
        dt = self.config.timestep
        total = int(np.ceil(times[-1] / dt)) + round(self.config.settle_time / dt)
        start_wall = time.perf_counter()
        for k in range(1, total + 1):
            t = k * dt
            index = min(int(np.searchsorted(times, t)), len(times) - 1)
            target = np.array([np.interp(t, times, positions[:, j]) for j in range(len(self.arm))])
            self.set_targets(target, closed[index])
            self.step()
            if realtime:
                ahead = k * dt - (time.perf_counter() - start_wall)
                if ahead > 0:
                    time.sleep(ahead)
        return total
