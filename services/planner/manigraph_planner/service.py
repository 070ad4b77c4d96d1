"""The planner service: serves one policy over the bus (and, for GNN policies, explains it)."""

from __future__ import annotations

import threading
import time

from manigraph_planner.decisions import DecisionMaker
from manigraph_planner.explain.handler import ExplainHandler
from manigraph_planner.policies.base import Policy
from manigraph_shared.bus import Bus
from manigraph_shared.errors import PolicyError
from manigraph_shared.messages import (
    Action,
    Checkpoint,
    EpisodeEvent,
    EstopState,
    ExplainRequest,
    Scene,
    SkillStatus,
)
from manigraph_shared.scene_gate import SceneGate
from manigraph_shared.service import Service


class PlannerService(Service):
    """Decides on scenes; answers ``manigraph/planner/explain`` queries.

    Explain queries run on a Zenoh thread against the explainer's own copy of the network,
    so they never delay or disturb a decision.

    Scenes pass a :class:`~manigraph_shared.scene_gate.SceneGate` first: one of another episode
    than the running one, or jumping far ahead in sequence or stamp, is refused and counted.
    A decision whose skill never reports is given up after ``decision_timeout`` seconds
    (``skill_timeout``), or at once when the skills service's liveliness token goes
    (``skills_lost``); either is logged and published as an error status. While the emergency
    stop is engaged, or the skills service is gone, the planner decides nothing.

    Args:
        bus: the process's bus.
        policy: the policy served.
        explain_decisions: also publish an ``Explanation`` after every decision (GNN only),
            so explanations land in the MCAP log beside the decisions.
        decision_timeout: seconds a decision may wait for its skill's final status.
        decide_on_arrival: handle scenes, statuses, events and stops on the Zenoh thread
            they arrive on when the service is idle (:meth:`Service.on` ``inline``), saving
            two thread hand-overs on the way to the skill; off where one process serves
            several cells, so that their decisions run on their own threads rather than one
            after another on Zenoh's, and with ``explain_decisions`` (an explanation, on the
            service thread, follows every decision; one queued behind a decision made on
            arrival was lost when the stack stopped right after the episode's last one).
        checkpoint: the file ``policy`` was loaded from, and its SHA-256 (for the status).

    A planner process serving several cells runs one of these per cell
    (:mod:`manigraph_shared.cell_services`), sharing only ``policy``: each has its own scene
    gate, decisions and recovery history, and its own explainer, so one cell's explanations
    (or a flood of explain queries, refused ``explainer_busy``) never hold up another's.
    """

    name = "planner"

    tick_period = 0.25  # how often a pending decision is checked for its deadline

    def __init__(
        self,
        bus: Bus,
        policy: Policy,
        explain_decisions: bool = False,
        decision_timeout: float = 30.0,
        decide_on_arrival: bool = True,
        checkpoint: Checkpoint | None = None,
    ) -> None:
        super().__init__(bus)
        self.policy = policy.name
        self.checkpoint = checkpoint
        # Explaining every decision makes each one a few hundred milliseconds of the service
        # thread's (the explanation follows its action there), so nothing is gained on arrival.
        self.decide_on_arrival = decide_on_arrival and not explain_decisions
        self.decisions = DecisionMaker(policy, decision_timeout=decision_timeout)
        self.gate = SceneGate()
        self.skills_alive = True
        self.explain = ExplainHandler(policy, self.decisions.history)
        self.explain_decisions = explain_decisions

    def setup(self) -> None:
        if self.explain_decisions and not self.explain.available:
            raise PolicyError(f"explain_decisions: {self.explain.problem}")
        if self.explain_decisions:
            self.explain.prepare()  # every decision is explained: have it before the first
        # Every handler is short (at most one decision), so all may run on arrival: a status
        # or an event handed to the service thread would hold the turn when the scene after
        # it arrives, and the decision would then wait for the hand-over too.
        inline = self.decide_on_arrival
        self.on(EpisodeEvent, self._on_episode, inline=inline)
        self.on(
            SkillStatus,
            lambda status: self._act(self.decisions.on_status(status)),
            inline=inline,
        )
        self.on(Scene, self._on_scene, inline=inline)
        self.bus.watch_alive(self._on_liveliness)
        self.bus.serve(ExplainRequest, self.explain)
        self.log.info(
            "serving policy '%s'%s",
            self.decisions.policy.name,
            " (explaining every decision)" if self.explain_decisions else "",
        )
        if self.explain.available and not self.explain_decisions:
            # Explain queries may come any time: build the explainer beside the decisions
            # rather than in the first query's time (the service answers scenes meanwhile).
            threading.Thread(target=self._prepare_explainer, name="explainer", daemon=True).start()

    def on_estop(self, state: EstopState) -> None:
        # Any thread: no decision from now on (unknown, before the latch answers, is engaged);
        # what was held is dropped on the service thread.
        self.decisions.stopped = state.engaged
        self.call_soon(lambda _: self.decisions.on_stop(state.engaged))

    def _prepare_explainer(self) -> None:
        try:
            self.explain.prepare()
            self.log.info("explainer ready")
        except Exception as exc:  # reported; each explain query then says why again
            self.log.exception("the explainer could not be built")
            self.call_soon(self.report_error, exc)

    def _on_episode(self, event: EpisodeEvent) -> None:
        overtaking = self.gate.on_episode(event)
        self.decisions.on_episode(event)
        for scene in overtaking:  # refused before this event reached us; acceptable now
            self._on_scene(scene)

    def _on_scene(self, scene: Scene) -> None:
        if not self.admit(self.gate, scene):
            return
        if not self.skills_alive:  # nobody would execute it; decide once skills is back
            return
        self._act(self.decisions.on_scene(scene))

    def _on_liveliness(self, service: str, alive: bool) -> None:
        if service == "skills":  # Zenoh thread: hand it to the service thread
            self.call_soon(self._skills_changed, alive)

    def _skills_changed(self, alive: bool) -> None:
        self.skills_alive = alive
        self._check_pending()

    def tick(self) -> None:
        self._check_pending()

    def _check_pending(self) -> None:
        pending = self.decisions.pending
        reason = self.decisions.give_up(time.monotonic(), self.skills_alive)
        if reason is not None:
            self.report_error(
                PolicyError(
                    f"{reason}: decision {pending} given up "
                    + (
                        "(the skills service went away)"
                        if reason == "skills_lost"
                        else f"(no final status within {self.decisions.decision_timeout:g} s)"
                    )
                )
            )

    def _act(self, action: Action | None) -> None:
        if action is None:
            return
        self.bus.publish(action)  # first: the log line costs ~50 us the skill need not wait
        self.log.info(
            "%s: %s -> %s (scene %d)",
            action.decision_id,
            action.object_id,
            action.goal_id,
            action.scene_sequence,
        )
        if self.explain_decisions:  # after the action: the skill starts while we explain
            explanation = self.explain.explain_action(action)
            if explanation is not None:
                self.bus.publish(explanation)
