"""The physics world as a sim backend: seeded task layouts, joint trajectories, a Panda.

Layouts come from the same registered tasks as the geometric backend, so a seed gives the
same blocks and goals in both worlds. The task's family (``families``) builds its part of the
simulated world and reads the simulated poses back by its own rules: its Scene and whether its
goals are filled (the block family: the geometric world's rule, a block fills a goal when its
centre is within ``goal_tolerance`` metres of the goal's centre and it is not held). The
default tolerance, 2 cm (half a block), accepts a block that settled a few millimetres off but
not one resting on the neighbouring place or tipped over.

Steps are counted per finished skill of the episode (``SkillStatus``, failed ones too); the
episode ends when every required goal is filled with the gripper open, or when the step
budget is spent.
"""

from __future__ import annotations

import logging
from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from manigraph_shared.errors import ConfigError, SkillError
from manigraph_shared.grasp_points import grasp_height
from manigraph_shared.messages import (
    REFUSAL_REASONS,
    EpisodeEvent,
    EpisodeRequest,
    GripperTarget,
    JointState,
    JointTrajectoryCommand,
    JointTrajectoryResult,
    RobotCommand,
    RobotFeedback,
    Scene,
    SkillStatus,
)
from manigraph_shared.preflight import INSTALL_VULKAN
from manigraph_sim.backend_base import EpisodeBackend, JointedArmBackend
from manigraph_sim.family import Evaluation, PhysicsTaskWorld
from manigraph_sim.manifest import CAMERA, JOINTS
from manigraph_sim.physics.physics_world import ARM_JOINTS, PhysicsConfig, PhysicsWorld
from manigraph_sim.physics.video import EpisodeVideo, VideoConfig, vulkan_available
from manigraph_sim.tasks.from_request import episode_layout
from manigraph_sim.world_model import Body, Layout

if TYPE_CHECKING:
    from manigraph_shared.markers import MarkerMap
    from manigraph_shared.messages import CameraInfo, CompressedImage, DepthImage, TaskLayout
    from manigraph_sim.physics.camera import CameraConfig, TripodCamera

log = logging.getLogger("manigraph.sim")

#: A body whose grasp point (a block's centre, a cover's handle) is this close to the TCP
#: while the gripper is closed is held.
HELD_DISTANCE = 0.03
#: A trajectory must start within this many radians (every joint) of where the arm is.
START_TOLERANCE = 0.05


class PhysicsBackend(EpisodeBackend, JointedArmBackend):
    """Runs as fast as it can, or in real time with ``realtime=True``. Registered as
    ``physics`` (options: ``manigraph_sim.backends.PhysicsOptions``)."""

    abilities = frozenset({JOINTS, CAMERA})

    def __init__(
        self,
        goal_tolerance: float = 0.02,
        realtime: bool = False,
        config: PhysicsConfig | None = None,
        stream_hz: tuple[float, float] = (30.0, 100.0),
        video: VideoConfig | None = None,
        camera: CameraConfig | None = None,
        markers: MarkerMap | None = None,
    ) -> None:
        super().__init__()
        self.goal_tolerance = goal_tolerance
        self.realtime = realtime
        #: With ``realtime``: the Scene and JointState rates a robot streams while it moves.
        self.stream_hz = stream_hz
        #: Called after every physics step of a motion in real time (the sim service
        #: publishes what is due from it); None: nothing streams during a motion.
        self.while_moving: Callable[[], None] | None = None
        self.video_config = video
        self.video: EpisodeVideo | None = None
        #: The tripod camera (``--camera``) and the markers printed on the bodies it sees.
        self.camera_config = camera
        self.camera: TripodCamera | None = None
        if camera is not None and camera.markers and markers is None:
            from manigraph_shared.markers import sim_marker_map

            markers = sim_marker_map()
        self.markers = markers
        #: Files written by the video recorder, one per ended episode.
        self.videos_written: list[Path] = []
        self.config = config or PhysicsConfig()
        #: The running episode's world: its task family's reading of the simulator
        #: (``world``), None before the first episode.
        self.task_world: PhysicsTaskWorld | None = None
        self.layout: Layout | None = None
        self.physics_steps = 0
        self._warm_world: PhysicsWorld | None = None
        if camera is not None:
            self._warm_up()

    @classmethod
    def from_options(cls, options: Any) -> PhysicsBackend:
        if options.camera_depth and not options.camera:
            raise ConfigError("camera-depth", "renders the camera's depth: needs --camera")
        if (options.video or options.camera) and not vulkan_available():
            raise ConfigError(
                "camera" if options.camera else "video",
                "SAPIEN found no Vulkan rendering device (a driver is installed, but none "
                f"answers): {INSTALL_VULKAN}",
            )
        video = VideoConfig(str(options.video)) if options.video else None
        camera = None
        if options.camera:
            from manigraph_sim.physics.camera import CameraConfig
            from manigraph_sim.physics.depth_noise import DepthNoise

            camera = CameraConfig(
                hz=options.camera_hz,
                noise_sigma=options.camera_noise,
                blur_pixels=options.camera_blur,
                depth=DepthNoise(scale=options.depth_noise) if options.camera_depth else None,
                markers=not options.camera_depth,
                light_scale=options.camera_light,
                pose_error=(options.camera_offset, options.camera_tilt),
            )
        return cls(
            options.goal_tolerance,
            options.realtime,
            stream_hz=(options.scene_hz, options.joint_state_hz),
            video=video,
            camera=camera,
        )

    @property
    def stream_rates(self) -> tuple[float, float] | None:
        """Scene and JointState rates (Hz) in real time; None when running flat out."""
        return self.stream_hz if self.realtime else None

    @property
    def world(self) -> PhysicsWorld | None:
        """The simulator of the running episode (arm, bodies), None before the first."""
        return None if self.task_world is None else self.task_world.physics

    # --- episodes ---------------------------------------------------------------------------
    def reset(self, request: EpisodeRequest, stamp: float) -> EpisodeEvent:
        episode = episode_layout(request, "physics")
        family, layout = episode.family, episode.layout
        if self.markers is not None and self.camera_config is not None:
            self.markers.check_objects((body.id, body.category) for body in layout.bodies)

        def make_world(bodies: list[Body]) -> PhysicsWorld:
            return PhysicsWorld(
                bodies,
                self.config,
                render=self.video_config is not None or self.camera_config is not None,
                containers=layout.containers,
                markers=self.markers if self.camera_config is not None else None,
            )

        self.task_world = family.physics_world(layout, make_world, self.goal_tolerance)
        world = self.task_world.physics
        self._warm_world = None
        if self.video_config is not None:
            self.video = EpisodeVideo(self.video_config, world.scene, self.config.timestep)
            world.on_step.append(self.video.on_step)
            self.video.capture()
        if self.camera_config is not None:
            from manigraph_sim.physics.camera import TripodCamera, light

            if self.video_config is None:
                light(world.scene, self.camera_config.light_scale)
            sequence = self.camera.sequence if self.camera is not None else 0
            self.camera = TripodCamera(self.camera_config, world.scene)
            self.camera.sequence = sequence
            self._warn_out_of_view(request, layout)
        self.layout = layout
        return self.begin(request, family.required_goals(layout), episode.max_steps, stamp)

    def _warn_out_of_view(self, request: EpisodeRequest, layout: Layout) -> None:
        """Name every body that starts partly outside the camera's picture: a perception that
        finds objects by sight (RGB-D, markers) cannot find it, and the episode will wait."""
        from manigraph_sim.physics.camera import out_of_view, top_corners

        assert self.camera is not None
        # The rendered camera's own pose: with --camera-offset/--camera-tilt it is not the
        # nominal one.
        k, base_T_camera = self.camera.camera_matrix(), self.camera.base_T_camera()
        size = (self.camera.config.width, self.camera.config.height)
        unseen = [
            f"{body.id} at ({body.position[0]:.2f}, {body.position[1]:.2f})"
            for body in layout.bodies
            if out_of_view(k, base_T_camera, size, top_corners(body.position, body.size))
        ]
        if unseen and request.episode_id != "warm-up":
            log.warning(
                "camera: %s start%s outside the camera's picture: perception cannot find %s "
                "(episode %s, seed %s); draw starts the camera sees (docs/perception.md)",
                ", ".join(unseen),
                "s" if len(unseen) > 1 else "",
                "them" if len(unseen) > 1 else "it",
                request.episode_id,
                request.seed,
            )

    def _warm_up(self) -> None:
        """Render one frame of a one-block episode: the first frame of a process compiles the
        shaders (10-40 s on a busy CPU), better before the service says it is ready than
        inside a reset someone is waiting for. It says how far it is every few seconds."""
        from manigraph_sim.physics.warm_up import progress_while

        what = "camera: warming up the renderer"
        with progress_while(log, what, "its first frame compiles shaders, 15-40 s"):
            self.reset(EpisodeRequest(episode_id="warm-up", task="stack", blocks=1), 0.0)
            self.camera_frame(0.0)
        # Kept until the next episode's world exists: SAPIEN frees the compiled shaders
        # with the last scene.
        self._warm_world = self.world
        self.task_world = None
        self.layout = self.request = self.camera = None
        self.ended = True

    def held(self) -> str | None:
        """The body whose grasp point is between the closed fingers, if any."""
        if self.world is None or self.layout is None or not self.world.gripper_closed:
            return None
        tcp = self.world.tcp_position()
        for body in self.layout.bodies:
            position = self.world.pose(body.id)[0]
            position[2] += grasp_height(body.category, body.size)
            if np.linalg.norm(position - tcp) < HELD_DISTANCE:
                return body.id
        return None

    def scene(self, stamp: float) -> Scene | None:
        if self.task_world is None or self.request is None:
            return None
        self.sequence += 1
        return self.task_world.scene(
            self.request.episode_id, stamp, self.sequence, self.ended, self.held()
        )

    def layout_message(self, stamp: float) -> TaskLayout | None:
        """The running episode's objects, goals and boxes (for a Scene source that cannot
        see goals: perception)."""
        if self.layout is None or self.request is None:
            return None
        from manigraph_sim.layout_message import layout_message

        return layout_message(self.layout, self.request.episode_id, stamp)

    def camera_frame(self, stamp: float) -> tuple[CompressedImage, CameraInfo] | None:
        """The tripod camera's view now, with its intrinsics; None without ``--camera``."""
        if self.camera is None:
            return None
        return self.camera.capture(stamp), self.camera.info(stamp)

    def camera_depth(self) -> DepthImage | None:
        """The depth frame of the last ``camera_frame`` (None without ``--camera-depth``)."""
        return None if self.camera is None else self.camera.last_depth

    def joint_state(self, stamp: float) -> JointState | None:
        if self.world is None:
            return None
        return JointState(
            joint_names=list(ARM_JOINTS),
            positions=self.world.arm_q.tolist(),
            gripper_width=self.world.gripper_width,
            stamp=stamp,
        )

    # --- commands ---------------------------------------------------------------------------
    def execute(self, command: RobotCommand, stamp: float) -> RobotFeedback:
        """Cartesian gripper commands are the geometric world's; a physical arm is moved by
        joint trajectories (the skills driver ``panda-sim`` plans them)."""
        return RobotFeedback(
            command_id=command.command_id,
            ok=False,
            reason="unsupported",
            detail="the physics sim takes JointTrajectoryCommand: run skills --driver panda-sim",
            stamp=stamp,
        )

    def execute_trajectory(
        self, command: JointTrajectoryCommand, stamp: float
    ) -> JointTrajectoryResult:
        """Follow ``command`` with the PD drives."""
        try:
            if self.halted.is_set():
                raise SkillError("stopped", "emergency stop engaged")
            if self.world is None or self.ended:
                raise SkillError("no_episode", "no episode is running")
            if tuple(command.joint_names) != ARM_JOINTS:
                raise SkillError("bad_joints", f"expected joints {', '.join(ARM_JOINTS)}")
            gap = np.max(np.abs(np.array(command.points[0].positions) - self.world.arm_q))
            if gap > START_TOLERANCE:
                # Planned from a stale joint state (e.g. before a reset): the answer carries
                # the actual joints, so the driver can plan again from there.
                raise SkillError("start_mismatch", f"first point is {gap:.3f} rad from the arm")
            times = np.array([p.time_from_start for p in command.points])
            positions = np.array([p.positions for p in command.points])
            closed = [p.gripper is GripperTarget.CLOSED for p in command.points]
            self.physics_steps += self.world.follow(
                times,
                positions,
                closed,
                self.realtime,
                halt=self.halted.is_set,
                while_moving=self.while_moving,
                openings=[p.opening for p in command.points],
            )
            if self.halted.is_set():
                raise SkillError("stopped", "emergency stop during the trajectory")
        except SkillError as exc:
            return self._result(command, stamp, exc.reason, exc.detail)
        return self._result(command, stamp)

    def _result(
        self, command: JointTrajectoryCommand, stamp: float, reason: str | None = None, detail=""
    ) -> JointTrajectoryResult:
        world = self.world
        return JointTrajectoryResult(
            command_id=command.command_id,
            ok=reason is None,
            reason=reason,
            detail=detail,
            positions=world.arm_q.tolist() if world else [],
            gripper_width=world.gripper_width if world else 0.0,
            stamp=stamp,
        )

    def skill_finished(self, status: SkillStatus) -> None:
        """Count every finished skill of this episode, failed ones too, against the step
        budget: a skill that fails before moving (no IK solution) still ends the episode
        once the budget is spent, instead of leaving it running forever."""
        if self.request is None or self.ended or not status.state.terminal:
            return
        if status.reason in REFUSAL_REASONS:  # refused before any motion: not a step
            return
        if status.decision_id.startswith(f"{self.request.episode_id}:"):
            self.steps += 1
            self._check_end()

    def _check_end(self) -> None:
        if self.world is None or self.ended:
            return
        done = not self.world.gripper_closed and self.evaluation().success
        self.ended = done or self.steps >= self.max_steps

    def evaluation(self) -> Evaluation:
        assert self.task_world is not None
        return self.task_world.evaluate(self.held())

    def sim_seconds(self) -> float | None:
        """Physics time simulated in this episode (motions and settling, without the
        settling of the layout before the first decision)."""
        if self.world is None:
            return None
        return max(0.0, self.world.sim_time - self.config.settle_time)

    def episode_ended(self) -> None:
        if self.video is not None and self.request is not None:
            self.videos_written.append(self.video.write(self.request.episode_id, self.request.seed))
