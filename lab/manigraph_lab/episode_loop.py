"""Episodes in one process: the geometric world, a policy, and the same messages as the stack.

This is what ``manigraph eval`` and ``manigraph demos`` run: no bus, so thousands of episodes
take seconds, but every step goes through the contract's ``Scene`` and ``RobotCommand`` so the
in-process result is the result the services would produce (a test checks that parity).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from manigraph_planner.policies.base import Policy
from manigraph_shared.messages import (
    Action,
    EpisodeEvent,
    EpisodeRequest,
    GripperOp,
    RobotCommand,
    Scene,
    Vector3,
)
from manigraph_sim.backend import SimBackend
from manigraph_sim.geometric.backend import GeometricBackend


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


def add_noise(scene: Scene, sigma: float, rng: np.random.Generator) -> Scene:
    """The scene as a noisy camera would report it: Gaussian noise on every position."""
    if sigma <= 0:
        return scene

    def jitter(position: Vector3) -> Vector3:
        dx, dy, dz = rng.normal(0.0, sigma, 3)
        return Vector3(x=position.x + dx, y=position.y + dy, z=position.z + dz)

    return scene.model_copy(
        update={
            "objects": [
                o.model_copy(update={"position": jitter(o.position)}) for o in scene.objects
            ],
            "goals": [g.model_copy(update={"position": jitter(g.position)}) for g in scene.goals],
        }
    )


def run_episode(
    policy: Policy,
    request: EpisodeRequest,
    noise: float = 0.0,
    backend_factory: Callable[[], SimBackend] = GeometricBackend,
) -> EpisodeRecord:
    """One episode to its end (success, step budget, or a policy with nothing to do).

    Observation noise reaches the policy only; the robot acts on the object and goal the
    policy named, at their true poses, as a PickAndPlace primitive with its own grasp
    perception would. The noise stream is seeded by the episode seed.
    """
    backend = backend_factory()
    clock = 0.0
    start = backend.reset(request, clock)
    rng = np.random.default_rng([request.seed, 7919])
    record_steps: list[Step] = []
    step = 0
    while True:
        clock += 1.0
        end = backend.end_event(clock)
        if end is not None:
            return EpisodeRecord(request, start, end, record_steps)
        truth = backend.scene(clock)
        assert truth is not None
        observed = add_noise(truth, noise, rng)
        decision = policy.decide(observed)
        if decision is None:
            return EpisodeRecord(request, start, _stuck(backend, request, clock), record_steps)
        action = decision.to_action(truth, step, policy.name, clock)
        step += 1
        ok, reason = _pick_and_place(backend, truth, action, clock)
        record_steps.append(Step(observed, action, ok, reason))


def _pick_and_place(
    backend: SimBackend, truth: Scene, action: Action, clock: float
) -> tuple[bool, str | None]:
    item = truth.object(action.object_id)
    goal = truth.goal(action.goal_id)
    for op, position in ((GripperOp.PICK, item.position), (GripperOp.PLACE, goal.position)):
        feedback = backend.execute(
            RobotCommand(
                command_id=f"{action.decision_id}.{op}",
                decision_id=action.decision_id,
                op=op,
                object_id=item.id,
                position=position,
                stamp=clock,
            ),
            clock,
        )
        if not feedback.ok:
            return False, feedback.reason
    return True, None


def _stuck(backend: SimBackend, request: EpisodeRequest, clock: float) -> EpisodeEvent:
    """The policy had nothing to do before the goals were filled: a failed episode."""
    assert isinstance(backend, GeometricBackend)
    backend.ended = True
    end = backend.end_event(clock)
    assert end is not None
    return end.model_copy(update={"reason": "policy had nothing to do"})
