"""A SAPIEN 3 tabletop: the Panda, the table, 4 cm blocks, static open boxes and covers with
a handle (``manigraph_shared.grasp_points``); physics only unless rendering.

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
from typing import TYPE_CHECKING

import numpy as np
import sapien
from sapien import physx

from manigraph_shared.colours import colour_of
from manigraph_shared.errors import ConfigError
from manigraph_shared.grasp_points import COVER_HANDLE_SIZE, handle_offset
from manigraph_shared.panda import ARM_JOINTS, FINGER_OPEN, HOME_Q, panda_urdf_path
from manigraph_sim.world_model import Body, Container

if TYPE_CHECKING:
    from manigraph_shared.markers import MarkerMap

#: Where an episode starts: Franka's "ready" pose with the hand turned a quarter, TCP at
#: (0.31, 0, 0.49) m, high and close to the base so it clears every stack of a layout.
#: (The skills' motion model starts its plans from the same pose.)
TABLE_COLOUR = [0.62, 0.5, 0.38, 1.0]
BOX_COLOUR = [0.75, 0.72, 0.65, 1.0]
COVER_COLOUR = [0.45, 0.42, 0.38, 1.0]
#: Block colours when rendering (RGBA), cycled by block index, for blocks whose attributes
#: name no colour of their own.
BLOCK_COLOURS = [
    [0.85, 0.25, 0.2, 1.0],
    [0.2, 0.55, 0.85, 1.0],
    [0.95, 0.75, 0.2, 1.0],
    [0.3, 0.7, 0.35, 1.0],
    [0.6, 0.35, 0.75, 1.0],
    [0.95, 0.5, 0.15, 1.0],
]


def body_colour(body: Body, index: int) -> list[float]:
    """The RGBA a body is rendered in: the colour its attributes name (``colour = "red"``,
    ``manigraph_shared.colours``), else the cycled block colour of its index."""
    named = colour_of(body.attributes)
    return [*named, 1.0] if named is not None else BLOCK_COLOURS[index % len(BLOCK_COLOURS)]


def body_parts(body: Body) -> list[tuple[sapien.Pose, np.ndarray]]:
    """A body's collision boxes (pose relative to the body's centre, half size): a block;
    a cover's plate and the handle on top of it."""
    parts = [(sapien.Pose(), body.size / 2)]
    if body.category == "cover":
        parts.append((sapien.Pose([0.0, 0.0, handle_offset(body.size)]), COVER_HANDLE_SIZE / 2))
    return parts


def box_walls(box: Container) -> list[tuple[sapien.Pose, np.ndarray]]:
    """An open box's four walls around ``box.inner``, ``box.height`` tall (pose relative to
    the box's centre on the table, half size)."""
    walls = []
    half_outer = box.inner / 2 + box.wall
    for axis in (0, 1):
        for side in (-1.0, 1.0):
            centre = np.array([0.0, 0.0, box.height / 2])
            centre[axis] = side * (box.inner[axis] + box.wall) / 2
            half = np.array([half_outer[0], half_outer[1], box.height / 2])
            half[axis] = box.wall / 2
            walls.append((sapien.Pose(centre), half))
    return walls


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
    cover_density: float = 400.0  # kg / m^3 (a plastic crate lid): a 27 cm cover ~0.3 kg
    settle_time: float = 0.2  # seconds simulated after a motion so things come to rest

    def __post_init__(self) -> None:
        if not 1e-4 <= self.timestep <= 0.05:
            raise ConfigError("physics.timestep", "must be in [1e-4, 0.05] seconds")
        for name in ("drive_stiffness", "drive_damping", "block_density", "cover_density"):
            if getattr(self, name) <= 0:
                raise ConfigError(f"physics.{name}", "must be > 0")
        for name in ("finger_friction", "block_friction", "table_friction", "settle_time"):
            if getattr(self, name) < 0:
                raise ConfigError(f"physics.{name}", "must be >= 0")

    def density(self, category: str) -> float:
        return self.cover_density if category == "cover" else self.block_density


#: The default material of a shape given none (static and dynamic friction, restitution):
#: SAPIEN 3's own.
DEFAULT_MATERIAL = (0.3, 0.3, 0.1)


def use_own_physx_defaults() -> None:
    """Set SAPIEN's process-wide PhysX defaults (scene, body and shape configuration, the
    default material) to SAPIEN 3's own, which every world here was tuned and measured with.

    They are globals that other code changes: ManiSkill sets its own (more solver iterations,
    a thinner contact offset, other friction) on every environment it builds, and a world
    built after one in the same process then ran with them. A bowl set down beside a turned
    one came to rest 15 mm off its slot after the ManiSkill tests, within 10 mm alone
    (issue 33). So every world sets them again before it builds anything."""
    physx.set_scene_config()
    physx.set_body_config()
    physx.set_shape_config()
    physx.set_default_material(*DEFAULT_MATERIAL)


class PhysicsWorld:
    """One episode's SAPIEN scene. Build a new one per episode: a fresh scene stepped with
    the same commands gives the same result (seeded determinism).

    Boxes (``containers``) are static: four walls standing on the table, open at the top.
    With ``render=True`` the robot and bodies also get visual shapes (for a video camera);
    that needs a Vulkan device; with ``markers`` too, bodies carry their printed ArUco
    markers. ``on_step`` callbacks run after every physics step.
    """

    def __init__(
        self,
        bodies: list[Body],
        config: PhysicsConfig | None = None,
        render: bool = False,
        containers: list[Container] | None = None,
        markers: MarkerMap | None = None,
    ) -> None:
        self.config = config or PhysicsConfig()
        c = self.config
        self.render = render
        self.markers = markers if render else None
        self.on_step: list[Callable[[], None]] = []
        use_own_physx_defaults()
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
        self.material = physx.PhysxMaterial(c.block_friction, c.block_friction, 0.0)
        for box in containers or []:
            self._add_box(box)
        self.entities: dict[str, sapien.Entity] = {}
        for index, body in enumerate(bodies):
            self.entities[body.id] = self._add_body(body, body_colour(body, index))
        self.set_targets(HOME_Q, closed=False)
        self.robot.set_qpos(np.concatenate([HOME_Q, [FINGER_OPEN, FINGER_OPEN]]))
        self.step(round(c.settle_time / c.timestep))

    def _add_body(self, body: Body, colour: list[float]) -> sapien.Entity:
        """A dynamic block, or a cover (plate and handle one rigid body, its pose the
        plate's centre)."""
        builder = self.scene.create_actor_builder()
        cover = body.category == "cover"
        density = self.config.density(body.category)
        for pose, half in body_parts(body):
            builder.add_box_collision(pose, half, material=self.material, density=density)
            if self.render:
                builder.add_box_visual(pose, half, material=COVER_COLOUR if cover else colour)
        if self.markers is None:
            entity = builder.build(name=body.id)
        else:
            from manigraph_sim.physics.camera import marker_shapes

            # Shapes can only join a render body before it joins an entity.
            render_body = builder.build_render_component()
            for shape in marker_shapes(self.markers, body.id, body.size):
                render_body.attach(shape)
            entity = sapien.Entity()
            entity.name = body.id
            entity.add_component(render_body)
            entity.add_component(builder.build_physx_component())
            self.scene.add_entity(entity)
        entity.set_pose(sapien.Pose(body.position))
        return entity

    def _add_box(self, box: Container) -> None:
        builder = self.scene.create_actor_builder()
        for pose, half in box_walls(box):
            builder.add_box_collision(pose, half, material=self.material)
            if self.render:
                builder.add_box_visual(pose, half, material=BOX_COLOUR)
        entity = builder.build_static(name=box.id)
        entity.set_pose(sapien.Pose([box.centre[0], box.centre[1], 0.0]))

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
        """Centre (x, y, z) and orientation quaternion (x, y, z, w) of a body (a cover's:
        its plate's)."""
        pose = self.entities[body_id].pose
        w, x, y, z = (float(v) for v in pose.q)  # SAPIEN stores (w, x, y, z)
        return np.asarray(pose.p, dtype=float), np.array([x, y, z, w])

    def tcp_position(self) -> np.ndarray:
        for link in self.robot.links:
            if link.name == "panda_hand_tcp":
                return np.asarray(link.entity_pose.p, dtype=float)
        raise ConfigError("panda_urdf", "no panda_hand_tcp link")

    # --- motion -----------------------------------------------------------------------------
    def set_targets(self, arm_q: np.ndarray, closed: bool, opening: float | None = None) -> None:
        """Drive the arm towards ``arm_q`` and the fingers closed, or open ``opening`` apart
        (None: fully)."""
        for joint, value in zip(self.arm, arm_q, strict=True):
            joint.set_drive_target(float(value))
        finger = FINGER_OPEN if opening is None else min(opening / 2, FINGER_OPEN)
        for joint in self.fingers:
            joint.set_drive_target(0.0 if closed else finger)
        self.gripper_closed = closed
        self.opening = opening

    def step(self, count: int = 1) -> None:
        for _ in range(count):
            self.scene.step()
            for callback in self.on_step:
                callback()
        self.sim_time += count * self.config.timestep

    def follow(
        self,
        times: np.ndarray,
        positions: np.ndarray,
        closed: list[bool],
        realtime: bool,
        halt: Callable[[], bool] | None = None,
        while_moving: Callable[[], None] | None = None,
        openings: list[float | None] | None = None,
    ) -> int:
        """Track the trajectory step by step (linear between points), then settle.
        ``halt`` (checked every step) stops the arm where it is: the emergency stop.
        With ``realtime`` each step waits for its moment of wall-clock time, and
        ``while_moving`` runs after each one (to publish the state a robot streams while it
        moves). ``openings``: how far the fingers open at each point (None: fully).
        Returns the number of physics steps taken."""
        dt = self.config.timestep
        total = int(np.ceil(times[-1] / dt)) + round(self.config.settle_time / dt)
        # Every step's target at once (the same interpolation as step by step, bit for bit):
        # per-step np.interp of each joint was an eighth of a PickAndPlace's wall time.
        moments = np.arange(1, total + 1) * dt
        points = np.minimum(np.searchsorted(times, moments), len(times) - 1).tolist()
        targets = np.stack(
            [np.interp(moments, times, positions[:, j]) for j in range(len(self.arm))], axis=1
        )
        start_wall = time.perf_counter()
        for k in range(1, total + 1):
            if halt is not None and halt():
                self.set_targets(self.arm_q.copy(), self.gripper_closed, self.opening)
                self.step()
                return k
            index = points[k - 1]
            self.set_targets(targets[k - 1], closed[index], openings[index] if openings else None)
            self.step()
            if realtime:
                ahead = k * dt - (time.perf_counter() - start_wall)
                if ahead > 0:
                    time.sleep(ahead)
                if while_moving is not None:
                    while_moving()
        return total
