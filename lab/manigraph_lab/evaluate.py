"""``manigraph eval``: a policy over N seeded episodes of one task, in one process."""

from __future__ import annotations

import statistics
import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import TextIO

from manigraph_lab.episode_loop import EpisodeRecord, run_episode
from manigraph_planner.policies.base import Policy
from manigraph_shared.decision_failure import OUT_OF_OPTIONS
from manigraph_shared.errors import DrawRefused
from manigraph_shared.messages import EpisodeRequest
from manigraph_shared.progress import Progress
from manigraph_tools.episode_plan import episode_size


@dataclass(frozen=True)
class EvalSpec:
    task: str
    blocks: int
    stacks: int = 1
    episodes: int = 100
    seed: int = 0
    noise: float = 0.0
    task_file: str | None = None  # TOML text of a user layout
    task_file_name: str | None = None  # what episodes and the summary are named after
    rules: str | None = None  # TOML text of rules only the judge (and the teacher) know
    objects: int | None = None  # dishwasher
    preference: str | None = None  # dishwasher

    def requests(self) -> list[EpisodeRequest]:
        label = self.task_file_name or f"{self.task}-{self.blocks}"
        return [
            EpisodeRequest(
                episode_id=f"eval-{label}-{self.seed + i}",
                task="file" if self.task_file is not None else self.task,
                blocks=self.blocks,
                stacks=self.stacks,
                objects=self.objects,
                options={"preference": self.preference} if self.preference is not None else {},
                seed=self.seed + i,
                task_file=self.task_file,
                rules=self.rules,
            )
            for i in range(self.episodes)
        ]


def evaluate(
    policy: Policy | Callable[[EpisodeRequest], Policy],
    spec: EvalSpec,
    progress: TextIO | None = None,
    checkpoint: dict[str, object] | None = None,
) -> dict[str, object]:
    """Play ``spec``'s episodes; ``policy``: who plays every episode, or who plays each one
    by its request (``demo_recording.family_experts``: its family's expert); ``progress``:
    stream for a bar, drawn only on a terminal; ``checkpoint``: the policy's file
    (``results.checkpoint_field``), named in the summary."""
    records: list[EpisodeRecord] = []
    refused: list[dict[str, object]] = []
    started = time.perf_counter()
    decisions = 0
    requests = spec.requests()
    players = [policy if isinstance(policy, Policy) else policy(r) for r in requests]
    name = "+".join(dict.fromkeys(player.name for player in players))  # each once, in order
    label = f"eval {name} {spec.task_file_name or spec.task} K={spec.blocks}"
    with Progress(spec.episodes, label, unit="episode", stream=progress) as bar:
        for request, player in zip(requests, players, strict=True):
            try:
                record = run_episode(player, request, noise=spec.noise)
            except DrawRefused as exc:  # this seed's draw only: the others still run
                refused.append({"seed": request.seed, "reason": str(exc)})
                bar.note(f"  refused {spec.task_file_name}, seed {request.seed}: {exc}")
                bar.update()
                continue
            records.append(record)
            decisions += len(record.steps)
            bar.status(f"success {sum(r.success for r in records) / len(records):.3f}")
            bar.update()
    seconds = time.perf_counter() - started
    summary = summarize(name, spec, records, seconds, decisions, checkpoint)
    if refused:
        summary["refused_seeds"] = refused
    return summary


def success_rate(
    policy: Policy | Callable[[EpisodeRequest], Policy],
    spec: EvalSpec,
    progress: TextIO | None = None,
) -> float:
    """The fraction of ``spec``'s episodes that ``policy`` finishes."""
    return float(evaluate(policy, spec, progress)["success_rate"])  # type: ignore[arg-type]


def summarize(
    policy: str,
    spec: EvalSpec,
    records: list[EpisodeRecord],
    seconds: float,
    decisions: int,
    checkpoint: dict[str, object] | None = None,
) -> dict[str, object]:
    count = len(records)
    failures: dict[str, int] = {}
    for record in records:
        for step in record.steps:
            if not step.ok:
                failures[step.reason or "unknown"] = failures.get(step.reason or "unknown", 0) + 1
    return {
        "policy": policy,
        **(checkpoint or {}),
        "task": spec.task,
        **({"task_file": spec.task_file_name} if spec.task_file is not None else {}),
        # blocks and stacks, or what the task's family sizes its episodes by (as `up` does)
        **episode_size(spec.task, spec),
        "noise": spec.noise,
        "seed": spec.seed,
        "episodes": count,
        "success_rate": sum(r.success for r in records) / count if count else 0.0,
        "goals_filled_rate": statistics.fmean(
            r.end.goals_filled / max(r.end.goals_total, 1) for r in records
        )
        if count
        else 0.0,
        "mean_steps": statistics.fmean(len(r.steps) for r in records) if count else 0.0,
        # Goals left holding an object they do not accept, over all episodes' ends.
        "wrong_object": sum(r.end.goals_wrong_object for r in records),
        # Placements the judge's rules refused, counted even when later undone.
        **(
            {"rule_violations": sum(r.end.rule_violations for r in records)}
            if spec.rules is not None
            else {}
        ),
        "infeasible_actions": failures,
        # The skills' refusals by reason (the same count as infeasible_actions, by the name
        # `run` and `up --episodes` give it), and the episodes that ran out of options.
        "refusals": dict(sorted(failures.items(), key=lambda item: -item[1])),
        "out_of_options": sum(r.end.reason.startswith(OUT_OF_OPTIONS) for r in records),
        "decisions_per_second": decisions / seconds if seconds > 0 else 0.0,
        "seconds": round(seconds, 3),
    }
