"""``manigraph demos``: expert demonstrations recorded as MCAP through the message contract.

A demonstration log holds, per step, the ``Scene`` the expert decided on and its ``Action``
(with ``scene_sequence`` pointing at that scene), plus the episode's start and end events,
written by :class:`~manigraph_shared.demonstrations.DemonstrationLog`, the writer the
demonstration page (``manigraph demo-ui``) uses too. A log recorded from a running stack
(``manigraph up --record``) has the same channels, so a user's own runs are training data too.

Each episode is demonstrated by its task family's expert (:func:`family_expert`): the sim's
family registry says which family the task is, the planner's registration of that family
which of its experts demonstrates the request (the dishwasher's: the one of its preference).
With a task file (``--task-file``) every episode is a seeded draw of that layout, demonstrated
by the block family's ``expert`` policy, which solves any task file (objects matched to the
goals that accept them; ``manigraph_planner.policies.matching``).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import TextIO

from manigraph_lab.episode_loop import run_episode
from manigraph_planner.family import FAMILIES as PLANNER_FAMILIES
from manigraph_planner.policies.base import Policy
from manigraph_planner.policies.teacher_rules import with_rules
from manigraph_shared.demonstrations import DemonstrationLog
from manigraph_shared.errors import DrawRefused
from manigraph_shared.messages import EpisodeRequest
from manigraph_shared.progress import Progress
from manigraph_sim.family import family_of


@dataclass(frozen=True)
class DemoProtocol:
    """The paper's default: 20 trajectories of box packing and unpacking with K = 3, 4."""

    tasks: tuple[str, ...] = ("box-pack", "box-unpack")
    blocks: tuple[int, ...] = (3, 4)
    trajectories: int = 20
    seed: int = 0
    #: The dishwasher task's dishes and preference (other tasks ignore them).
    objects: int | None = None
    preference: str | None = None
    #: A task file's TOML text: every episode draws that layout (``tasks`` and ``blocks``
    #: are then unused); ``task_file_name`` names the episodes.
    task_file: str | None = None
    task_file_name: str = "task-file"
    #: Rules only the teacher and the judge know (``--rules``): the expert follows them, the
    #: recorded scenes never show them.
    rules: str | None = None

    def requests(self) -> list[EpisodeRequest]:
        if self.task_file is not None:
            return [
                EpisodeRequest(
                    episode_id=f"demo-{i:03d}-{self.task_file_name}",
                    task="file",
                    blocks=self.blocks[0] if self.blocks else 1,
                    seed=self.seed + i,
                    task_file=self.task_file,
                    rules=self.rules,
                )
                for i in range(self.trajectories)
            ]
        combos = [(t, k) for t in self.tasks for k in self.blocks]
        return [
            EpisodeRequest(
                episode_id=f"demo-{i:03d}-{combos[i % len(combos)][0]}",
                task=combos[i % len(combos)][0],
                blocks=combos[i % len(combos)][1],
                objects=self.objects,
                options={"preference": self.preference} if self.preference is not None else {},
                seed=self.seed + i,
            )
            for i in range(self.trajectories)
        ]


def family_expert(request: EpisodeRequest) -> Policy:
    """A fresh expert for ``request``: its task's family (the sim's registry, by task name or
    task file) as the planner registers it says which of its experts demonstrates it."""
    return PLANNER_FAMILIES[family_of(request).name].expert(request)


def family_experts(
    rules: str | None = None, source: str = "rules file"
) -> Callable[[EpisodeRequest], Policy]:
    """Who plays each episode when no policy is named (``manigraph eval``'s default): its
    family's expert (:func:`family_expert`), one instance per expert for every episode it
    plays, told the rules of ``rules`` (a task file's, named ``source``) when given."""
    experts: dict[str, Policy] = {}

    def expert_for(request: EpisodeRequest) -> Policy:
        fresh = family_expert(request)
        if fresh.name not in experts:
            experts[fresh.name] = with_rules(fresh, rules, source)
        return experts[fresh.name]

    return expert_for


def record_demos(
    expert: Policy | None, protocol: DemoProtocol, path: Path, progress: TextIO | None = None
) -> dict[str, object]:
    """Record ``protocol``'s episodes to ``path``; ``expert``: who decides, None: each task's
    family's expert (:func:`family_expert`); ``progress``: stream for a bar (drawn on a
    terminal only) and for a note on each episode the expert failed."""
    log = DemonstrationLog(path)
    steps = successes = 0
    requests = protocol.requests()
    bar = Progress(len(requests), "demos", unit="episode", stream=progress)
    try:
        for request in requests:
            teacher = expert if expert is not None else family_expert(request)
            try:
                record = run_episode(with_rules(teacher, protocol.rules), request)
            except DrawRefused as exc:  # this seed's draw only: the others still run
                bar.update()
                bar.note(f"  refused {protocol.task_file_name}, seed {request.seed}: {exc}")
                continue
            bar.update()
            if not record.success:
                bar.note(f"  skipped {request.episode_id}: the expert failed")
                continue
            successes += 1
            steps += log.write(
                record.start, [(s.scene, s.action) for s in record.steps], record.end
            )
            bar.status(f"{steps} decisions")
    finally:
        bar.close()
        log.close()
    return {"file": str(path), "trajectories": successes, "decisions": steps}
