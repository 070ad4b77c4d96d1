"""What a sim backend offers the sim service (registered by name in ``manigraph_sim.backends``)."""

from __future__ import annotations

import threading
from abc import ABC, abstractmethod
from typing import Any, ClassVar

from manigraph_shared.messages import (
    EpisodeEvent,
    EpisodePhase,
    EpisodeRequest,
    JointState,
    JointTrajectoryCommand,
    JointTrajectoryResult,
    RobotCommand,
    RobotFeedback,
    Scene,
    SkillStatus,
)
from manigraph_sim.family import Evaluation


class SimBackend(ABC):
    """A world that can be reset into a seeded episode, observed and commanded.

    All methods take and return contract messages, so the logic is testable without a bus.
    ``abilities`` are the optional ports of the sim's manifest (``manigraph_sim.manifest``)
    that this backend serves.
    """

    abilities: ClassVar[frozenset[str]] = frozenset()

    @classmethod
    def from_options(cls, options: Any) -> SimBackend:
        """The backend configured by its registered options (``manigraph_sim.backends``)."""
        return cls()

    @abstractmethod
    def reset(self, request: EpisodeRequest, stamp: float) -> EpisodeEvent:
        """Lay out a new episode; returns its start event."""

    @abstractmethod
    def scene(self, stamp: float) -> Scene | None:
        """The current observation, or None before the first episode."""

    @abstractmethod
    def execute(self, command: RobotCommand, stamp: float) -> RobotFeedback:
        """Carry out one robot command."""

    @abstractmethod
    def end_event(self, stamp: float) -> EpisodeEvent | None:
        """The end event, once, when the episode has just ended; else None."""

    def skill_finished(self, status: SkillStatus) -> None:
        """A skill reported ``status``; a backend that counts steps by finished skills (the
        physics world, whose robot takes many trajectories per skill) overrides this."""


class JointedArmBackend(SimBackend):
    """A world whose robot is a jointed arm: it executes joint trajectories and reports joint
    state (the manifest's ``joint_trajectories`` ability)."""

    @abstractmethod
    def execute_trajectory(
        self, command: JointTrajectoryCommand, stamp: float
    ) -> JointTrajectoryResult:
        """Follow ``command``'s trajectory (and gripper action) to its end."""

    @abstractmethod
    def joint_state(self, stamp: float) -> JointState | None:
        """The arm's joints now, or None before the first episode."""


class EpisodeBackend(SimBackend):
    """A backend's episode bookkeeping: the request, the step budget, and start and end
    events. Subclasses lay out their world (a task family's world adapter), say how the
    episode stands by the family's rule (:meth:`evaluation`) and decide when it has ended
    (``ended``)."""

    def __init__(self) -> None:
        self.request: EpisodeRequest | None = None
        #: The running episode's required goals (its family's ``required_goals``).
        self.required: set[str] = set()
        self.steps = 0
        self.max_steps = 0
        self.sequence = 0
        self.ended = True
        self._end_reported = True
        #: Why the episode was cut short (:meth:`cut`); empty: it ended by its own rules.
        self.cut_reason = ""
        #: Set while the emergency stop is engaged (from any thread): no motion at all.
        self.halted = threading.Event()

    def emergency_stop(self, engaged: bool) -> None:
        """Engage or release the emergency stop; a motion under way stops at once."""
        if engaged:
            self.halted.set()
        else:
            self.halted.clear()

    def begin(
        self, request: EpisodeRequest, required: set[str], max_steps: int, stamp: float
    ) -> EpisodeEvent:
        """Start ``request``'s episode (its world laid out, ``required``: the ids of the goals
        its family counts); returns its start event."""
        self.request = request
        self.required = required
        self.steps = 0
        self.max_steps = max_steps
        self.ended = False
        self._end_reported = False
        self.cut_reason = ""
        return self._event(EpisodePhase.START, stamp)

    def cut(self, reason: str) -> bool:
        """End the running episode now, unfinished, for ``reason`` (an emergency stop); its end
        event says so. False when no episode is running."""
        if self.ended or self.request is None:
            return False
        self.ended = True
        self.cut_reason = reason
        return True

    @abstractmethod
    def evaluation(self) -> Evaluation:
        """How the running episode stands by its family's rule (``families.base``)."""

    def required_filled(self) -> int:
        """Required goals filled now (by the family's rule)."""
        return self.evaluation().filled

    def end_event(self, stamp: float) -> EpisodeEvent | None:
        if not self.ended or self._end_reported or self.request is None:
            return None
        self._end_reported = True
        self.episode_ended()
        return self._event(EpisodePhase.END, stamp)

    def episode_ended(self) -> None:
        """Called once as the end event is made (e.g. to write the episode's video)."""

    def sim_seconds(self) -> float | None:
        """Simulated time this episode has taken, for a world with a clock; else None."""
        return None

    def _event(self, phase: EpisodePhase, stamp: float) -> EpisodeEvent:
        assert self.request is not None
        return episode_event(
            self.request,
            phase,
            stamp,
            self.evaluation(),
            steps=self.steps,
            max_steps=self.max_steps,
            sim_seconds=self.sim_seconds() if phase is EpisodePhase.END else None,
            cut_reason=self.cut_reason,
        )


def episode_event(
    request: EpisodeRequest,
    phase: EpisodePhase,
    stamp: float,
    evaluation: Evaluation,
    *,
    steps: int,
    max_steps: int,
    sim_seconds: float | None = None,
    cut_reason: str = "",
) -> EpisodeEvent:
    """The start or end event of ``request``'s episode: an episode ends in success exactly when
    its family's rule says so (``evaluation``: every required goal filled), else because its
    step budget is spent. The end event counts the goals holding an object they do not accept
    (``wrong_object``). An episode cut short (``cut_reason``, e.g. ``estop_engaged: ...``)
    ends unsuccessful for that reason."""
    success = None
    reason = ""
    ended = phase is EpisodePhase.END
    wrong_object = evaluation.wrong_object if ended else 0
    if ended and cut_reason:
        success, reason = False, cut_reason[:256]
    elif ended:
        success = evaluation.success
        reason = "all goals filled" if success else f"step budget {max_steps} spent"
        if not success and wrong_object:
            hold = "goals hold" if wrong_object != 1 else "goal holds"
            reason += f"; {wrong_object} {hold} an object it does not accept"
    return EpisodeEvent(
        episode_id=request.episode_id,
        phase=phase,
        task=request.task,
        seed=request.seed,
        goals_total=evaluation.total,
        goals_filled=evaluation.filled,
        steps=steps,
        goals_wrong_object=wrong_object,
        rule_violations=evaluation.rule_violations if ended else 0,
        success=success,
        reason=reason,
        sim_seconds=None if sim_seconds is None else round(sim_seconds, 3),
        stamp=stamp,
    )
