"""The manigraph tasks as ManiSkill 3 environments, so ManiSkill users can ``gym.make`` them.

    import gymnasium as gym
    import manigraph_blocks.sim.maniskill_env  # registers the environments
    env = gym.make("Manigraph-Stack-v0", blocks=3, obs_mode="state")

Layouts come from the same registered tasks and seeds as the physics sim service
(``reset(seed=s)`` lays out what ``--sim physics --seed s`` does, box tasks with the physical
box geometry), with ManiSkill's own Panda agent at the origin of a table at z = 0. Boxes are
kinematic actors moved to each episode's sites; covers are dynamic, with their handle. The
state observation is complete: the box rearrangement's partial observability is the
manigraph sim's (its ``Scene``), not modelled here. ManiSkill needs a Vulkan device even for
state observations (see ``scripts/install-vulkan.sh`` on CPU-only machines).

**Success Conditions**: every required goal holds an object of its category: its centre
within ``goal_tolerance`` (2 cm) of the goal's, the geometric world's rule; the gripper has
let go.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import sapien
import torch
from mani_skill.agents.robots import Panda
from mani_skill.envs.sapien_env import BaseEnv
from mani_skill.sensors.camera import CameraConfig
from mani_skill.utils import sapien_utils
from mani_skill.utils.building.ground import build_ground
from mani_skill.utils.registration import register_env
from mani_skill.utils.structs.pose import Pose

from manigraph_blocks.sim.options import BlockOptions
from manigraph_blocks.sim.physics_boxes import PHYSICS_BOXES
from manigraph_sim.physics.physics_world import (
    BOX_COLOUR,
    COVER_COLOUR,
    FINGER_OPEN,
    HOME_Q,
    PhysicsConfig,
    body_colour,
    body_parts,
    box_walls,
)
from manigraph_sim.tasks import get_task
from manigraph_sim.world_model import Layout


class ManigraphEnv(BaseEnv):
    """A manigraph task with the Panda; a subclass per task names it (``ENVIRONMENTS``; CPU
    simulation, one env)."""

    SUPPORTED_ROBOTS = ["panda"]
    agent: Panda
    task_name: str = "stack"

    def __init__(
        self,
        *args: Any,
        blocks: int = 3,
        stacks: int = 1,
        goal_tolerance: float = 0.02,
        robot_uids: str = "panda",
        **kwargs: Any,
    ) -> None:
        params = BlockOptions(blocks=blocks, stacks=stacks, boxes=PHYSICS_BOXES)
        self.task = get_task(self.task_name, params)
        self.goal_tolerance = goal_tolerance
        probe = self.task.layout(np.random.default_rng(0))
        self.body_ids = [body.id for body in probe.bodies]
        self.layout: Layout = probe
        super().__init__(*args, robot_uids=robot_uids, **kwargs)

    @property
    def _default_sensor_configs(self) -> list[CameraConfig]:
        pose = sapien_utils.look_at(eye=[1.0, 0.6, 0.6], target=[0.45, 0.0, 0.1])
        return [CameraConfig("base_camera", pose, 128, 128, np.pi / 3, 0.01, 10)]

    @property
    def _default_human_render_camera_configs(self) -> CameraConfig:
        pose = sapien_utils.look_at(eye=[1.05, 0.6, 0.55], target=[0.42, 0.0, 0.12])
        return CameraConfig("render_camera", pose, 480, 360, 0.9, 0.01, 10)

    def _load_agent(self, options: dict) -> None:
        super()._load_agent(options, sapien.Pose(p=[0.0, 0.0, 0.0]))

    def _load_scene(self, options: dict) -> None:
        """Every body and box of the task, parked off the table until an episode lays them
        out (their number and sizes are the same for every seed)."""
        self.ground = build_ground(self.scene, altitude=0.0)
        config = PhysicsConfig()
        visible = self.scene.can_render()  # no visual shapes with render_backend="none"
        self.blocks = {}  # every body by id: blocks and covers
        for i, body in enumerate(self.layout.bodies):
            builder = self.scene.create_actor_builder()
            cover = body.category == "cover"
            colour = COVER_COLOUR if cover else body_colour(body, i)
            density = config.density(body.category)
            for pose, half in body_parts(body):
                builder.add_box_collision(pose, half, density=density)
                if visible:
                    builder.add_box_visual(pose, half, material=colour)
            builder.initial_pose = sapien.Pose(p=[1.0 + 0.3 * i, 1.0, 0.1])
            self.blocks[body.id] = builder.build(name=body.id)
        self.boxes = {}
        for i, box in enumerate(self.layout.containers):
            builder = self.scene.create_actor_builder()
            for pose, half in box_walls(box):
                builder.add_box_collision(pose, half)
                if visible:
                    builder.add_box_visual(pose, half, material=BOX_COLOUR)
            builder.initial_pose = sapien.Pose(p=[1.0 + 0.3 * i, -1.0, 0.0])
            self.boxes[box.id] = builder.build_kinematic(name=box.id)

    def _initialize_episode(self, env_idx: torch.Tensor, options: dict) -> None:
        seed = int(self._episode_seed[0])
        self.layout = self.task.layout(np.random.default_rng(seed))
        for box in self.layout.containers:
            self.boxes[box.id].set_pose(
                Pose.create_from_pq(p=torch.tensor([*box.centre, 0.0], dtype=torch.float32)[None])
            )
        for body in self.layout.bodies:
            self.blocks[body.id].set_pose(
                Pose.create_from_pq(p=torch.tensor(body.position, dtype=torch.float32)[None])
            )
        qpos = np.concatenate([HOME_Q, [FINGER_OPEN, FINGER_OPEN]])
        self.agent.reset(torch.tensor(qpos, dtype=torch.float32)[None])
        self.goal_positions = torch.tensor(
            np.array([goal.position for goal in self.layout.goals]), dtype=torch.float32
        )
        self.required = torch.tensor(
            [goal.id in self.layout.required_goals() for goal in self.layout.goals]
        )
        #: goal x body: the body's category fills the goal.
        self.fits = torch.tensor(
            [[g.category == b.category for b in self.layout.bodies] for g in self.layout.goals]
        )

    def _block_positions(self) -> torch.Tensor:
        return torch.stack([self.blocks[i].pose.p[0] for i in self.body_ids])

    def evaluate(self) -> dict[str, torch.Tensor]:
        distance = torch.cdist(self.goal_positions, self._block_positions())
        distance[~self.fits] = torch.inf
        filled = distance.min(dim=1).values <= self.goal_tolerance
        grasping = torch.stack(
            [self.agent.is_grasping(self.blocks[i])[0] for i in self.body_ids]
        ).any()
        done = bool(filled[self.required].all()) and not bool(grasping)
        return {
            "goals_filled": filled.sum()[None],
            "success": torch.tensor([done]),
        }

    def _get_obs_extra(self, info: dict) -> dict[str, torch.Tensor]:
        obs = {"tcp_pose": self.agent.tcp.pose.raw_pose}
        if "state" in self.obs_mode:
            poses = torch.stack([self.blocks[i].pose.raw_pose[0] for i in self.body_ids])
            # bodies in layout order (blocks, then covers) x (x, y, z, qw, qx, qy, qz)
            obs["block_poses"] = poses.reshape(1, -1)
            obs["goal_positions"] = self.goal_positions.reshape(1, -1)  # G x (x, y, z)
        return obs

    def compute_dense_reward(self, obs: Any, action: torch.Tensor, info: dict) -> torch.Tensor:
        """Sparse in effect: the fraction of goals filled."""
        return info["goals_filled"].float() / len(self.layout.goals)

    def compute_normalized_dense_reward(
        self, obs: Any, action: torch.Tensor, info: dict
    ) -> torch.Tensor:
        return self.compute_dense_reward(obs, action, info)


#: Each task as a ManiSkill environment: its id, manigraph's task, its step limit, what it is.
ENVIRONMENTS = (
    (
        "Manigraph-Stack-v0",
        "stack",
        2000,
        "K-block stacking (manigraph's ``stack`` task): build the inverted stack elsewhere.",
    ),
    (
        "Manigraph-Pyramid-v0",
        "pyramid",
        4000,
        "K-pyramid (manigraph's ``pyramid`` task) from one stack of K blocks.",
    ),
    (
        "Manigraph-MultiStack-v0",
        "multistack",
        4000,
        "K-block s-stack (manigraph's ``multistack`` task).",
    ),
    (
        "Manigraph-BoxPack-v0",
        "box-pack",
        4000,
        "Box packing (manigraph's ``box-pack`` task): cover off, blocks in, cover back on.",
    ),
    (
        "Manigraph-BoxUnpack-v0",
        "box-unpack",
        4000,
        "Box unpacking (manigraph's ``box-unpack`` task): cover off, blocks out, cover back.",
    ),
    (
        "Manigraph-BoxRearrangement-v0",
        "box-rearrangement",
        6000,
        "Box rearrangement (``box-rearrangement``): blocks from one closed box to the other.",
    ),
)


def _registered(env_id: str, task_name: str, max_episode_steps: int, doc: str) -> type:
    """A :class:`ManigraphEnv` subclass for ``task_name``, registered as ``env_id`` and named
    after it (``Manigraph-BoxPack-v0``: ``ManigraphBoxPackEnv``)."""
    name = f"Manigraph{env_id.split('-')[1]}Env"
    namespace = {"task_name": task_name, "__doc__": doc, "__module__": __name__}
    env = type(name, (ManigraphEnv,), namespace)
    env.__qualname__ = name
    return register_env(env_id, max_episode_steps=max_episode_steps)(env)


#: The registered environment classes by id.
ENV_CLASSES = {row[0]: _registered(*row) for row in ENVIRONMENTS}
