"""The proposing policy of ``demo-ui --propose P``: loaded in the page's own process and asked,
in a thread of its own, about every world the robot is free to act on.

It only proposes: what it decides goes to the session (:meth:`DemoSession.propose`), which
shows it and holds it; nothing here publishes. The policy is loaded as the planner loads one
(a registered name or a checkpoint, ``manigraph_planner.policies.load_policy``) but with no
rules file: what the page shows never comes from rules only the judge knows.
"""

from __future__ import annotations

import logging
import threading
from collections.abc import Callable

from manigraph_shared.errors import ConfigError, PolicyError
from manigraph_shared.messages import Scene
from manigraph_tools.click_page.clicks import Click
from manigraph_tools.click_page.session import DemoSession

log = logging.getLogger("manigraph.demo-ui.proposer")

#: A policy's decision on a scene, as the click that would send it (None: nothing to do).
Decide = Callable[[Scene], Click | None]
#: Seconds between looks at the session when nothing changes (and checks for shutdown).
WAIT = 1.0


def load_proposer(spec: str) -> Decide:
    """The policy ``spec`` (a registered name or a checkpoint file) as a :data:`Decide`;
    :class:`ConfigError` naming ``propose`` where it cannot be loaded."""
    try:
        from manigraph_planner.policies import load_policy
    except ImportError:
        raise ConfigError(
            "propose", "needs the planner package (manigraph-planner) installed beside the tools"
        ) from None
    try:
        policy = load_policy(spec)
    except PolicyError as exc:
        raise ConfigError("propose", str(exc)) from None

    def decide(scene: Scene) -> Click | None:
        decision = policy.decide(scene)
        if decision is None:
            return None
        return Click(
            decision.object_id,
            decision.goal_id,
            decision.orientation_index,
            decision.family_action,
        )

    return decide


class Proposer:
    """Asks ``decide`` about each world ``session`` wants a proposal for, until ``stopping``."""

    def __init__(self, session: DemoSession, decide: Decide, stopping: threading.Event) -> None:
        self.session = session
        self.decide = decide
        self.stopping = stopping
        self.thread = threading.Thread(target=self.run, name="demo-ui-proposer", daemon=True)

    def start(self) -> None:
        self.thread.start()

    def run(self) -> None:
        seen = -1
        while not self.stopping.is_set():
            seen = self.session.wait_changed(seen, WAIT)
            scene = self.session.wants_proposal()
            if scene is None:
                continue
            try:
                click = self.decide(scene)
            except Exception as exc:  # a policy's failure must not take the page down with it
                log.exception("the proposing policy failed on %s", scene.episode_id)
                self.session.say("error", f"the proposing policy failed: {exc}; click instead")
                self.session.propose(scene, None)
                continue
            self.session.propose(scene, click)
