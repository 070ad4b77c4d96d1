"""The sim service: wires a sim backend to the bus."""

from __future__ import annotations

import time
from collections.abc import Callable

from manigraph_shared.bus import Bus
from manigraph_shared.errors import BusError, ConfigError, ManigraphError
from manigraph_shared.estop_latch import stop_reason
from manigraph_shared.messages import (
    EpisodeEvent,
    EpisodeRequest,
    EstopState,
    JointTrajectoryCommand,
    RobotCommand,
    ServiceState,
    SkillStatus,
)
from manigraph_shared.service import Service
from manigraph_sim.backend_base import JointedArmBackend, SimBackend
from manigraph_sim.manifest import JOINTS
from manigraph_sim.tasks.from_request import check_request

#: Failures that refuse a command outright (counted as rejections in the status), as opposed
#: to a motion that was tried and failed.
REFUSED = frozenset(
    {"outside_workspace", "unknown_object", "no_episode", "stopped", "bad_joints", "unsupported"}
)

#: Seconds a reset query waits for the service thread to lay the episode out; then it is
#: answered ``reset_timeout``, an error of the runtime kind (``RequestFailed``, exit 1).
RESET_ANSWER_SECONDS = 30.0
RESET_TIMEOUT = "reset_timeout"

#: The sim's inbox lane for what moves the robot (``manigraph_shared.inbox``).
ROBOT_LANE = "robot"


class Cadence:
    """Says when something published at ``hz`` is due, keeping the rate over time (a late
    sample does not push every later one back; after a long stall it starts afresh)."""

    def __init__(self, hz: float) -> None:
        self.period = 1.0 / hz
        self.next = 0.0

    def due(self, now: float) -> bool:
        if now < self.next:
            return False
        self.next += self.period
        if self.next <= now:
            self.next = now + self.period
        return True


class SimService(Service):
    """Publishes ``Scene`` at ``publish_hz`` and right after every change, resets episodes on
    request, executes robot commands and reports episode start and end.

    A backend simulating in real time (``stream_rates``: Scene and JointState rates) streams
    as a robot does: the Scene at its rate all the time, and while the arm moves the
    JointState at its rate and the Scene at its rate, published from inside the motion."""

    name = "sim"

    def __init__(
        self,
        bus: Bus,
        backend: SimBackend,
        publish_hz: float = 10.0,
        scenes: bool = True,
        camera_hz: float = 0.0,
        plays: str | None = None,
    ) -> None:
        super().__init__(bus)
        #: The task file the stack was started with (``up --task-file``): a reset without a
        #: task file is refused naming it, not played as a registered task unsaid.
        self.plays = plays
        self.backend = backend
        self.tick_period = 1.0 / publish_hz
        rates: tuple[float, float] | None = getattr(backend, "stream_rates", None)
        self._streaming: tuple[Cadence, Cadence, Cadence] | None = None
        if rates is not None:
            scene_hz, joint_state_hz = rates
            self.tick_period = 0.25 / scene_hz  # ticks check the scenes' cadence
            # Scenes, joint states, and heartbeats (so a long motion is not taken for a stall).
            self._streaming = (Cadence(scene_hz), Cadence(joint_state_hz), Cadence(1.0))
            backend.while_moving = self._stream_while_moving  # type: ignore[attr-defined]
        #: False: perception is the Scene source; the sim only referees (episode events).
        self.scenes = scenes
        #: Camera frames per second of wall time (besides one right after every change).
        self.camera_period = 1.0 / camera_hz if camera_hz > 0 else None
        self._next_frame = 0.0

    def setup(self) -> None:
        # Resets arrive on a Zenoh thread; hand them to the service thread and wait.
        self.bus.serve(EpisodeRequest, self._reset_from_query)
        # Robot commands in a lane of their own: skills' statuses (one for every action it
        # refuses, and anyone may send it actions to refuse) can never push one out.
        self.on(RobotCommand, self._execute, lane=ROBOT_LANE)
        self.on(SkillStatus, self._on_skill_status)
        if JOINTS in self.backend.abilities:
            self.on(JointTrajectoryCommand, self._execute_trajectory, lane=ROBOT_LANE)

    def on_estop(self, state: EstopState) -> None:
        # On the thread that learned it: the service thread may be busy moving the arm, and
        # the motion must stop now, not after it. Unknown is engaged: the arm holds still.
        halt: Callable[[bool], None] | None = getattr(self.backend, "emergency_stop", None)
        if halt is not None:
            halt(state.engaged)
        if state.engaged and state.known:  # the episode under way ends, saying why, once
            self.call_soon(self._cut_episode, stop_reason(state.reason, state.by))

    def _cut_episode(self, reason: str) -> None:
        cut: Callable[[str], bool] | None = getattr(self.backend, "cut", None)
        if cut is not None and cut(reason):
            self._publish_scene()
            self._publish_end()

    def _reset_from_query(self, request: EpisodeRequest) -> EpisodeEvent:
        import queue

        # A task file is checked here, on the Zenoh thread: a refusal never waits for, nor
        # holds, the sim's thread.
        if self.plays is not None and request.task_file is None:
            raise ConfigError(
                "task-file",
                f"this stack plays {self.plays} (up --task-file), not task {request.task}; "
                f"run it with --task-file {self.plays}",
            )
        check_request(request)
        answer: queue.SimpleQueue[EpisodeEvent | BaseException] = queue.SimpleQueue()
        given_up = time.monotonic() + RESET_ANSWER_SECONDS

        def reset(_: object) -> None:
            if time.monotonic() >= given_up:  # its querier has had its answer: do not run it
                self.log.warning("reset %s not run: it waited too long", request.episode_id)
                return
            try:
                answer.put(self._reset(request))
            except BaseException as exc:  # handed back to the querier as an error reply
                answer.put(exc)

        if not self.call_soon(reset):
            raise BusError("sim busy: its inbox is full, try the reset again")
        try:
            result = answer.get(timeout=RESET_ANSWER_SECONDS)
        except queue.Empty:  # the runtime kind: the querier exits 1 naming it, not 78
            raise BusError(
                f"{RESET_TIMEOUT}: the reset was not done within {RESET_ANSWER_SECONDS:g} s "
                "(the sim is busy: a long task file or another reset); ask again later"
            ) from None
        if isinstance(result, BaseException):
            # Raised from here, the exception's traceback holds this frame, which would hold
            # the exception: a cycle that kept the bus's answering frame, and with it the Zenoh
            # query, alive until the garbage collector ran. The querier got the error reply at
            # once but its query ended only at its timeout (10 s or 30 s). Without the local,
            # the query ends when the reply is sent.
            try:
                raise result
            finally:
                del result
        return result

    def _reset(self, request: EpisodeRequest) -> EpisodeEvent:
        if self.estop.engaged:  # no episode starts while the robot must not move
            raise ManigraphError(self.estop.describe())
        event = self.backend.reset(request, time.time())
        self.log.info(
            "episode %s: %s K=%d s=%d seed %d",
            request.episode_id,
            request.task,
            request.blocks,
            request.stacks,
            request.seed,
        )
        self.bus.publish(event)
        self._publish_scene()
        return event

    def _execute(self, command: RobotCommand) -> None:
        feedback = self.backend.execute(command, time.time())
        if not feedback.ok:
            self.log.info("%s %s failed: %s", command.op, command.object_id, feedback.reason)
            if feedback.reason in REFUSED:
                self.reject(command, feedback.reason, command.command_id)
        self._publish_scene()
        self.bus.publish(feedback)
        self._publish_end()

    def _publish_end(self) -> None:
        end = self.backend.end_event(time.time())
        if end is not None:
            self.log.info(
                "episode %s ended: %s (%d/%d goals, %d steps)",
                end.episode_id,
                "success" if end.success else "failure",
                end.goals_filled,
                end.goals_total,
                end.steps,
            )
            self.bus.publish(end)

    def _stream_while_moving(self) -> None:
        """Inside a real-time motion, after each physics step: what a moving robot streams."""
        assert self._streaming is not None and isinstance(self.backend, JointedArmBackend)
        scenes, joint_states, heartbeats = self._streaming
        now = time.monotonic()
        if joint_states.due(now):
            state = self.backend.joint_state(time.time())
            if state is not None:
                self.bus.publish(state)
        if self.scenes and scenes.due(now):
            scene = self.backend.scene(time.time())
            if scene is not None:
                self.bus.publish(scene)
        if heartbeats.due(now):
            self.publish_status(ServiceState.OK, self.last_error)

    def _execute_trajectory(self, command: JointTrajectoryCommand) -> None:
        assert isinstance(self.backend, JointedArmBackend)
        result = self.backend.execute_trajectory(command, time.time())
        # Stamped when the motion ended (not when it began), so what was streamed during the
        # motion is older than the answer, and a scene stamped after it shows the end state.
        result = result.replace(stamp=time.time())
        if not result.ok:
            self.log.info("trajectory %s failed: %s", command.command_id, result.reason)
            if result.reason in REFUSED:
                self.reject(command, result.reason, command.command_id)
        self._publish_scene()
        self.bus.publish(result)
        self._publish_end()

    def _on_skill_status(self, status: SkillStatus) -> None:
        self.backend.skill_finished(status)
        if status.state.terminal:
            self._publish_scene()  # a fresh observation for the next decision, now
        self._publish_end()

    def _publish_scene(self) -> None:
        # The joint state first: perception learns from it that a carried block was let go
        # before it looks at the frame that may not show where the block landed.
        if isinstance(self.backend, JointedArmBackend):
            state = self.backend.joint_state(time.time())
            if state is not None:
                self.bus.publish(state)
        self._publish_frame()
        scene = self.backend.scene(time.time()) if self.scenes else None
        if scene is not None:
            self.bus.publish(scene)

    def _publish_frame(self) -> None:
        """A camera frame (and the layout it shows, so a late perception learns it too)."""
        if self.camera_period is None:
            return
        stamp = time.time()
        layout = self.backend.layout_message(stamp)  # type: ignore[attr-defined]
        frame = self.backend.camera_frame(stamp)  # type: ignore[attr-defined]
        self._next_frame = time.monotonic() + self.camera_period
        if layout is None or frame is None:
            return
        image, info = frame
        self.bus.publish(layout)
        self.bus.publish(info)
        depth = self.backend.camera_depth()  # type: ignore[attr-defined]
        if depth is not None:
            self.bus.publish(depth)  # before its image: a reader pairs them as the image comes
        self.bus.publish(image)

    def tick(self) -> None:
        if self.scenes:
            if self._streaming is not None and not self._streaming[0].due(time.monotonic()):
                return
            self._publish_scene()
        elif self.camera_period is not None and time.monotonic() >= self._next_frame:
            self._publish_frame()
