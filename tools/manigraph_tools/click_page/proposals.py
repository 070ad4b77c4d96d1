"""A policy's proposals on the page (``demo-ui --propose P``): shown, held, accepted or corrected.

The policy decides on the scene the page shows, and its decision is only *shown*: nothing is
published until the person clicks. Accept sends the proposed pair; clicking another object and
goal sends that pair instead. Either way it is the person's click, recorded like any other
step of a demonstration, and its ``Action.policy`` says which it was: ``human:accepted``,
``human:corrected`` (or ``human`` when the person clicked before the policy had proposed).

:class:`Proposals` is the state, with no lock, no thread and no policy of its own: the session
guards it and the service's proposer thread (``proposer.py``) asks the policy.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

from manigraph_shared.messages import Action, Scene
from manigraph_tools.click_page.clicks import (
    ACCEPTED,
    CORRECTED,
    POLICY,
    Click,
    ClickRefused,
    action_for,
    describe,
    same_decision,
)
from manigraph_tools.click_page.scene_view import same_world


@dataclass(frozen=True)
class Proposal:
    """What the policy proposed on ``scene``: ``action`` as Accept would send it."""

    action: Action
    scene: Scene


class Proposals:
    """The proposing policy's name (None: nobody proposes) and its proposal for the world."""

    def __init__(self, policy: str | None) -> None:
        self.policy = policy
        self.current: Proposal | None = None
        self.asked: Scene | None = None  # the world the policy was last asked about

    @property
    def enabled(self) -> bool:
        return self.policy is not None

    def wanted(self, scene: Scene) -> bool:
        """Whether the policy should be asked about ``scene`` (not asked about this world yet)."""
        return self.enabled and not same_world(self.asked, scene)

    def for_scene(self, scene: Scene | None) -> Proposal | None:
        """The proposal, if it was made on the world ``scene`` shows."""
        current = self.current
        if current is None or scene is None or not same_world(current.scene, scene):
            return None
        return current

    def offer(
        self,
        scene: Scene,
        click: Click | None,
        step: int,
        clock: Callable[[], float],
    ) -> tuple[str, str]:
        """Take the policy's ``click`` on ``scene`` (None: it has nothing to do); the message
        for the page, as ``(level, text)``. A proposal the page would refuse as a click is
        not shown, and says why."""
        self.asked = scene
        self.current = None
        if click is None:
            return "info", f"{self.policy} proposes nothing here: click what should happen"
        try:
            action = action_for(click, scene, scene.episode_id, step, clock, ACCEPTED)
        except ClickRefused as refusal:
            return "error", f"{self.policy} proposed what the page refuses ({refusal}): click"
        self.current = Proposal(action, scene)
        return "info", f"{self.policy} proposes {describe(action)}: accept it or click another"

    def label(self, action: Action, scene: Scene) -> str:
        """``Action.policy`` for the person's ``action`` on ``scene``: accepted, corrected, or
        plain ``human`` where nothing was proposed on that world."""
        proposal = self.for_scene(scene)
        if proposal is None:
            return POLICY
        return ACCEPTED if same_decision(action, proposal.action) else CORRECTED

    def forget(self) -> None:
        """The person has decided (or the episode changed): ask the policy afresh."""
        self.current = None
        self.asked = None

    def view(self, scene: Scene | None, thinking: bool) -> dict[str, object] | None:
        """The page's part: who proposes, whether it is thinking, and what it proposes."""
        if self.policy is None:
            return None
        proposal = self.for_scene(scene)
        action = proposal.action if proposal is not None else None
        return {
            "policy": self.policy,
            "thinking": thinking and proposal is None,
            "proposal": None
            if action is None
            else {
                "object_id": action.object_id,
                "goal_id": action.goal_id,
                "orientation_index": action.orientation_index,
                "family_action": action.family_action,
                "text": describe(action),
            },
        }
