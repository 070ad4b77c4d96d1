"""The geometric world as a sim backend: episodes, observations and a magic gripper."""

from __future__ import annotations

import numpy as np

from manigraph_shared.errors import SkillError
from manigraph_shared.messages import (
    EpisodeEvent,
    EpisodePhase,
    EpisodeRequest,
    GoalCategory,
    GripperOp,
    ObjectCategory,
    RobotCommand,
    RobotFeedback,
    Scene,
    SceneGoal,
    SceneObject,
    Vector3,
)
from manigraph_sim.backend import SimBackend, episode_event, register_backend
from manigraph_sim.geometric.world import GeometricWorld
from manigraph_sim.tasks.from_request import episode_layout


def _vec(values: np.ndarray) -> Vector3:
    return Vector3(x=float(values[0]), y=float(values[1]), z=float(values[2]))


@register_backend("geometric")
class GeometricBackend(SimBackend):
    def __init__(self, goal_tolerance: float = 0.01) -> None:
        self.goal_tolerance = goal_tolerance
        self.world: GeometricWorld | None = None
        self.required: set[str] = set()
        self.request: EpisodeRequest | None = None
        self.steps = 0
        self.max_steps = 0
        self.sequence = 0
        self.ended = True
        self._end_reported = True

    def reset(self, request: EpisodeRequest, stamp: float) -> EpisodeEvent:
        episode = episode_layout(request)
        layout = episode.layout
        self.world = GeometricWorld(
            layout.bodies,
            layout.goals,
            self.goal_tolerance,
            containers=layout.containers,
            hide_inside_closed=layout.partially_observable,
        )
        self.required = layout.required_goals()
        self.request = request
        self.steps = 0
        self.max_steps = episode.max_steps
        self.ended = False
        self._end_reported = False
        return self._event(EpisodePhase.START, stamp)

    def scene(self, stamp: float) -> Scene | None:
        if self.world is None or self.request is None:
            return None
        world = self.world
        world.observe()
        occupancy = world.occupancy()
        in_goal = set(occupancy.values())
        objects = [
            SceneObject(
                id=body.id,
                category=ObjectCategory(body.category),
                position=_vec(body.position),
                size=_vec(body.size),
                filled=body.id in in_goal,
                visible=not world.is_hidden(body.position),
            )
            for body in world.bodies.values()
        ]
        goals = [
            SceneGoal(
                id=goal.id,
                category=GoalCategory(goal.category),
                position=_vec(goal.position),
                filled=goal.id in occupancy,
                visible=not world.is_hidden(goal.position),
            )
            for goal in world.goals.values()
        ]
        self.sequence += 1
        return Scene(
            episode_id=self.request.episode_id,
            stamp=stamp,
            sequence=self.sequence,
            objects=objects,
            goals=goals,
            episode_ended=self.ended,
        )

    def execute(self, command: RobotCommand, stamp: float) -> RobotFeedback:
        try:
            if self.world is None or self.ended:
                raise SkillError("no_episode", "no episode is running")
            if command.op is GripperOp.PICK:
                self.steps += 1  # every attempted pick counts against the step budget
                self.world.pick(command.object_id)
            else:
                self.world.place(command.object_id, np.array(command.position.as_tuple()))
        except SkillError as exc:
            self._check_end()
            return RobotFeedback(
                command_id=command.command_id,
                ok=False,
                reason=exc.reason,
                detail=exc.detail,
                stamp=stamp,
            )
        self._check_end()
        return RobotFeedback(command_id=command.command_id, ok=True, stamp=stamp)

    def _check_end(self) -> None:
        if self.world is None or self.ended or self.world.held is not None:
            return
        if self.required_filled() == len(self.required) or self.steps >= self.max_steps:
            self.ended = True

    def required_filled(self) -> int:
        assert self.world is not None
        return len(self.required & self.world.occupancy().keys())

    def end_event(self, stamp: float) -> EpisodeEvent | None:
        if not self.ended or self._end_reported or self.world is None:
            return None
        self._end_reported = True
        return self._event(EpisodePhase.END, stamp)

    def _event(self, phase: EpisodePhase, stamp: float) -> EpisodeEvent:
        assert self.world is not None and self.request is not None
        return episode_event(
            self.request,
            phase,
            stamp,
            filled=self.required_filled(),
            total=len(self.required),
            steps=self.steps,
            max_steps=self.max_steps,
        )
