"""Episodes in one process: a sim backend, a policy, and the services' own logic.

This is what ``manigraph eval`` and ``manigraph demos`` run. There is no bus, so thousands of
episodes take seconds, but nothing is re-implemented either: decisions come from the planner's
``DecisionMaker``, and are executed by the skills' ``PickAndPlace`` with the skills' own robot
driver, whose commands a transport hands straight to the backend. In-process and distributed
runs therefore cannot drift apart (a test checks that they take the same decisions).

Time is a step clock: every message of step ``t`` is stamped ``t``, so logs (and the
demonstrations' data hash) are the same on every machine.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from manigraph_lab.in_process import InProcessGripperTransport, InProcessJointTransport
from manigraph_planner.decisions import DecisionMaker, OutOfOptions
from manigraph_planner.policies.base import Policy
from manigraph_shared.messages import (
    Action,
    EpisodeEvent,
    EpisodeRequest,
    Scene,
    SkillState,
    Vector3,
)
from manigraph_shared.workspace import Workspace
from manigraph_sim.backend_base import EpisodeBackend, SimBackend
from manigraph_sim.geometric.backend import GeometricBackend
from manigraph_sim.physics.backend import PhysicsBackend
from manigraph_skills.drivers.base import RobotDriver
from manigraph_skills.drivers.gripper import GripperDriver
from manigraph_skills.pick_and_place import PickAndPlace


@dataclass
class Step:
    scene: Scene  # what the policy saw
    action: Action
    ok: bool
    reason: str | None


@dataclass
class EpisodeRecord:
    request: EpisodeRequest
    start: EpisodeEvent
    end: EpisodeEvent
    steps: list[Step] = field(default_factory=list)

    @property
    def success(self) -> bool:
        return bool(self.end.success)


class StepClock:
    """The episode's clock: ``clock()`` is the current step's time; the loop advances it."""

    def __init__(self) -> None:
        self.now = 0.0

    def __call__(self) -> float:
        return self.now


def in_process_skill(
    backend: SimBackend,
    clock: StepClock,
    driver_factory: Callable[[SimBackend, StepClock], RobotDriver] | None = None,
    workspace: Workspace | None = None,
) -> PickAndPlace:
    """The skills' PickAndPlace on ``backend``, its driver's commands handed over directly."""
    driver = (driver_factory or gripper_driver)(backend, clock)
    return PickAndPlace(driver, workspace or Workspace(), clock)


def gripper_driver(backend: SimBackend, clock: StepClock) -> RobotDriver:
    """The geometric world's robot: the skills' gripper driver, commands straight to the world."""
    return GripperDriver(InProcessGripperTransport(backend), clock)


def panda_driver(backend: SimBackend, clock: StepClock | None = None) -> RobotDriver:
    """The physics world's robot: the skills' Panda driver, trajectories straight to the
    SAPIEN world (which keeps its own time, so ``clock`` is not used)."""
    from manigraph_skills.drivers.panda_motion import PandaMotionDriver  # Pinocchio: on demand

    if not isinstance(backend, PhysicsBackend):
        raise TypeError(f"the Panda driver needs a physics world, not {type(backend).__name__}")
    return PandaMotionDriver(InProcessJointTransport(backend))


def add_noise(scene: Scene, sigma: float, rng: np.random.Generator) -> Scene:
    """The scene as a noisy camera would report it: Gaussian noise on every position."""
    if sigma <= 0:
        return scene

    def jitter(position: Vector3) -> Vector3:
        dx, dy, dz = rng.normal(0.0, sigma, 3)
        return Vector3(x=position.x + dx, y=position.y + dy, z=position.z + dz)

    return scene.replace(
        objects=[o.replace(position=jitter(o.position)) for o in scene.objects],
        goals=[g.replace(position=jitter(g.position)) for g in scene.goals],
    )


def run_episode(
    policy: Policy,
    request: EpisodeRequest,
    noise: float = 0.0,
    backend_factory: Callable[[], SimBackend] = GeometricBackend,
    driver_factory: Callable[[SimBackend, StepClock], RobotDriver] = gripper_driver,
    workspace: Workspace | None = None,
) -> EpisodeRecord:
    """One episode to its end (success, step budget, or a policy with nothing to do).

    Observation noise reaches the policy only; the skill acts on the object and goal the
    policy named, at their true poses, as a PickAndPlace primitive with its own grasp
    perception would. The noise stream is seeded by the episode seed.
    """
    backend = backend_factory()
    clock = StepClock()
    start = backend.reset(request, clock())
    planner = DecisionMaker(policy, clock=clock)
    planner.on_episode(start)
    skill = in_process_skill(backend, clock, driver_factory, workspace)
    rng = np.random.default_rng([request.seed, 7919])
    steps: list[Step] = []
    while True:
        clock.now += 1.0
        end = backend.end_event(clock())
        if end is not None:
            return EpisodeRecord(request, start, end, steps)
        truth = backend.scene(clock())
        assert truth is not None
        observed = add_noise(truth, noise, rng)
        try:
            action = planner.on_scene(observed)
        except OutOfOptions as exc:  # every option refused: the episode ends, naming them
            return EpisodeRecord(request, start, _stuck(backend, clock(), exc.why), steps)
        if action is None:
            return EpisodeRecord(request, start, _stuck(backend, clock()), steps)
        status = skill.execute(action, truth, report=backend.skill_finished)
        planner.on_status(status)
        steps.append(Step(observed, action, status.state is SkillState.SUCCEEDED, status.reason))


def _stuck(
    backend: SimBackend, stamp: float, why: str = "policy had nothing to do"
) -> EpisodeEvent:
    """The policy had nothing to do (or nothing the skills would not refuse) before the goals
    were filled: a failed episode, ending for ``why``."""
    assert isinstance(backend, EpisodeBackend)
    backend.ended = True
    end = backend.end_event(stamp)
    assert end is not None
    return end.replace(reason=why[:256])
