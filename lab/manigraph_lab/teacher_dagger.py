"""``manigraph improve``: DAgger with the teacher.

Each round plays the current policy on a task file's seeded episodes (the geometric world in
process, as ``manigraph eval``), has the teacher (the generic expert following the rules file,
as ``manigraph demos --rules`` does) decide on every scene the policy was asked about, and
records each of those decisions as a demonstration of that scene: the Scene exactly as the
policy saw it (``filled`` from the task file alone), the teacher's Action beside it, written by
:class:`~manigraph_shared.demonstrations.DemonstrationLog`, the demonstration page's writer. Then
it retrains from scratch on the policy's own demonstrations (those its checkpoint names) plus
every round's labels, with the policy's own recipe (:mod:`.improve_recipe`). The next round
plays the policy just trained; the last one is the output.

Beside the output ``P2.pt`` go ``P2.round<N>.mcap`` (round N's labels) and ``P2.round<N>.pt``
(the policy round N trained; the last is ``P2.pt`` itself). ``P2.pt`` names its demonstrations
and every round's labels, so it can be improved again.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import TextIO

from manigraph_lab.demo_recording import family_expert
from manigraph_lab.episode_loop import run_episode
from manigraph_lab.improve_recipe import demos_of, recipe_of
from manigraph_planner.gnn import save_checkpoint
from manigraph_planner.gnn.features import FeatureSpec
from manigraph_planner.gnn.task_features import TaskFeatures
from manigraph_planner.policies import Decision, Policy, load_policy
from manigraph_planner.policies.gnn import GNNPolicy
from manigraph_planner.policies.teacher_rules import with_rules
from manigraph_planner.threads import use_threads
from manigraph_shared.demonstrations import DemonstrationLog
from manigraph_shared.errors import ConfigError, DrawRefused, LogError, ManigraphError, PolicyError
from manigraph_shared.messages import Action, EpisodeRequest, Scene
from manigraph_sim.geometric.backend import GeometricBackend
from manigraph_training.dataset import load_demonstrations, read_decisions
from manigraph_training.trainer import TrainConfig, train


@dataclass(frozen=True)
class ImprovePlan:
    policy: Path
    task_file: str  # the task file's text
    task_file_name: str  # what episodes are named after
    rules: str  # the rules file's text (the teacher's and the judge's)
    rules_name: str
    output: Path
    rounds: int = 2
    episodes: int = 10
    #: Round r plays seeds ``seed + (r - 1) * episodes`` on: none of the demonstrations'
    #: (0+) nor the reported evaluations'.
    seed: int = 3000
    device: str = "cpu"
    threads: int = 2  # torch's intra-op threads while training

    def __post_init__(self) -> None:
        for name in ("rounds", "episodes"):
            if getattr(self, name) < 1:
                raise ConfigError(name, "must be >= 1")
        if self.output.suffix != ".pt":
            raise ConfigError("output", f"{self.output}: a checkpoint file ends in .pt")

    def requests(self, round_: int) -> list[EpisodeRequest]:
        first = self.seed + (round_ - 1) * self.episodes
        return [
            EpisodeRequest(
                episode_id=f"improve-r{round_}-{self.task_file_name}-{seed}",
                task="file",
                blocks=1,
                seed=seed,
                task_file=self.task_file,
                rules=self.rules,
            )
            for seed in range(first, first + self.episodes)
        ]

    def beside(self, round_: int, suffix: str) -> Path:
        return self.output.with_name(f"{self.output.stem}.round{round_}{suffix}")


@dataclass
class RoundReport:
    round: int
    episodes: int = 0
    refused_seeds: list[int] = field(default_factory=list)
    successes: int = 0
    rule_violations: int = 0
    scenes_visited: int = 0
    labels: int = 0
    labels_file: str = ""
    final_loss: float = float("nan")
    demo_accuracy: float = float("nan")
    training_samples: int = 0
    train_seconds: float = 0.0
    seconds: float = 0.0
    checkpoint: str = ""

    @property
    def success_rate(self) -> float:
        return self.successes / self.episodes if self.episodes else 0.0

    def line(self, rounds: int) -> str:
        refused = f", {len(self.refused_seeds)} seeds refused" if self.refused_seeds else ""
        return (
            f"round {self.round}/{rounds}: {self.episodes} episodes{refused}, success "
            f"{self.success_rate:.2f} by the rules, {self.rule_violations} rule violations; "
            f"{self.labels} labels added ({self.scenes_visited} scenes visited) to "
            f"{self.labels_file}; retrained on {self.training_samples} samples: loss "
            f"{self.final_loss:.4f}, accuracy {self.demo_accuracy:.3f}, "
            f"{self.train_seconds:.0f} s; round {self.seconds:.0f} s"
        )

    def to_dict(self) -> dict[str, object]:
        return {
            "round": self.round,
            "episodes": self.episodes,
            **({"refused_seeds": self.refused_seeds} if self.refused_seeds else {}),
            "success_rate": round(self.success_rate, 4),
            "rule_violations": self.rule_violations,
            "scenes_visited": self.scenes_visited,
            "labels": self.labels,
            "labels_file": self.labels_file,
            "final_loss": self.final_loss,
            "demo_accuracy": self.demo_accuracy,
            "training_samples": self.training_samples,
            "train_seconds": self.train_seconds,
            "seconds": round(self.seconds, 2),
            "checkpoint": self.checkpoint,
        }


class VisitedScenes(Policy):
    """``policy`` as the planner asks it, keeping every scene it was asked to decide on."""

    def __init__(self, policy: Policy) -> None:
        self.policy = policy
        self.name = policy.name
        self.object_escalation = policy.object_escalation
        self.accepts_filter = policy.accepts_filter
        self.scenes: list[Scene] = []

    def decide(self, scene: Scene) -> Decision | None:
        self.scenes.append(scene)
        return self.policy.decide(scene)

    def ranked(self, scene: Scene) -> list[Decision]:
        return self.policy.ranked(scene)


def teacher_labels(teacher: Policy, scenes: list[Scene]) -> list[tuple[Scene, Action]]:
    """The teacher's decision on each scene, as a demonstration records it: the Action the
    planner would send (``Decision.to_action``, step by step, stamped with the scene's time)
    beside the scene as it was seen. A scene where the teacher has nothing to do has none."""
    labels: list[tuple[Scene, Action]] = []
    for scene in scenes:
        decision = teacher.decide(scene)
        if decision is not None:
            labels.append(
                (scene, decision.to_action(scene, len(labels), teacher.name, scene.stamp))
            )
    return labels


@dataclass(frozen=True)
class Student:
    """The policy to improve: its checkpoint, its demonstrations and its recipe."""

    policy: GNNPolicy
    demos: list[Path]
    recipe: TrainConfig
    spec: FeatureSpec


def load_student(plan: ImprovePlan) -> Student:
    """The policy of ``plan`` with its data and recipe, each checked against the task file;
    a named error (no traceback) for a checkpoint of another task or demonstrations that
    cannot be read."""
    source = str(plan.policy)
    policy = load_policy(source)
    if not isinstance(policy, GNNPolicy) or policy.info is None:
        raise PolicyError(f"{source}: improve retrains a GNN checkpoint, not {policy.name}")
    info = policy.info
    if "task" not in info.feature_spec:
        raise PolicyError(
            f"{source}: trained on the paper's block tasks, not on a task file: improve "
            f"teaches a policy learned from {plan.task_file_name}'s demonstrations"
        )
    recipe = recipe_of(info.training_config, source, plan.device)
    demos = demos_of(info.training_config, source)
    try:
        scenes, _ = read_decisions(demos)
        load_demonstrations(demos)
    except ManigraphError as exc:
        raise LogError(f"{source}: the demonstrations it was trained on: {exc}") from None
    except Exception as exc:  # the MCAP reader's own errors on a broken file
        raise LogError(
            f"{source}: the demonstrations it was trained on ({', '.join(map(str, demos))}) "
            f"cannot be read: {type(exc).__name__}: {exc}"
        ) from None
    spec = FeatureSpec.from_dict(info.feature_spec)
    _check_same_task(plan, source, list(scenes.values()), spec)
    return Student(policy, demos, recipe, spec)


def _check_same_task(
    plan: ImprovePlan, source: str, demo_scenes: list[Scene], spec: FeatureSpec
) -> None:
    """Refuse a checkpoint whose demonstrations are not of ``plan``'s task file: no goal in
    common, or objects with columns the policy never learned."""
    scene = _first_scene(plan)
    taught = {goal.id for s in demo_scenes for goal in s.goals}
    here = {goal.id for goal in scene.goals}
    if not taught & here:
        raise PolicyError(
            f"{source}: trained for another task: its demonstrations' goals "
            f"({', '.join(sorted(taught)[:6])}) are none of {plan.task_file_name}'s "
            f"({', '.join(sorted(here)[:6])})"
        )
    together = FeatureSpec.for_task(TaskFeatures.learn([*demo_scenes, scene]))
    if together != spec:
        new = [name for name in together.names if name not in spec.names]
        raise PolicyError(
            f"{source}: trained for another task: {plan.task_file_name}'s scenes need "
            f"columns it never learned ({', '.join(new) or 'other vocabularies'})"
        )


def _first_scene(plan: ImprovePlan) -> Scene:
    """A scene of the task file: the first of round 1's draws that succeeds."""
    for request in plan.requests(1):
        backend = GeometricBackend()
        try:
            backend.reset(request, 0.0)
        except DrawRefused:
            continue
        scene = backend.scene(0.0)
        if scene is not None:
            return scene
    raise ConfigError("task_file", f"{plan.task_file_name}: no seed of round 1 could be drawn")


def teacher_for(request: EpisodeRequest, rules: str, rules_name: str) -> Policy:
    """The teacher ``manigraph demos --rules`` records ``request`` with: its family's expert,
    told the rules."""
    return with_rules(family_expert(request), rules, rules_name)


def play_round(
    policy: Policy, plan: ImprovePlan, round_: int, log: DemonstrationLog
) -> RoundReport:
    """Round ``round_``'s episodes by ``policy``, each visited scene labelled into ``log``."""
    report = RoundReport(round_, labels_file=str(log.path))
    for request in plan.requests(round_):
        visits = VisitedScenes(policy)
        try:
            record = run_episode(visits, request)
        except DrawRefused:
            report.refused_seeds.append(request.seed)
            continue
        teacher = teacher_for(request, plan.rules, plan.rules_name)
        labels = teacher_labels(teacher, visits.scenes)
        log.write(record.start, labels, record.end)
        report.episodes += 1
        report.successes += record.success
        report.rule_violations += record.end.rule_violations
        report.scenes_visited += len(visits.scenes)
        report.labels += len(labels)
    return report


def improve(plan: ImprovePlan, progress: TextIO | None = None) -> dict[str, object]:
    """Run ``plan``'s rounds (module docstring); one line per round on ``progress``."""
    student = load_student(plan)
    plan.output.parent.mkdir(parents=True, exist_ok=True)
    policy: Policy = student.policy
    labelled: list[Path] = []
    reports: list[RoundReport] = []
    started = time.perf_counter()
    for round_ in range(1, plan.rounds + 1):
        round_started = time.perf_counter()
        log = DemonstrationLog(plan.beside(round_, ".mcap"))
        try:
            report = play_round(policy, plan, round_, log)
        finally:
            log.close()
        labelled.append(log.path)
        data = [*student.demos, *labelled]
        demos = load_demonstrations(data)
        use_threads(plan.threads)  # loading a policy sets one thread for its decisions
        net, metrics = train(demos, student.recipe)
        checkpoint = plan.output if round_ == plan.rounds else plan.beside(round_, ".pt")
        save_checkpoint(
            checkpoint,
            net,
            training_config={**student.recipe.to_dict(), "demos": [str(p) for p in data]},
            data_hash=demos.data_hash,
            metrics={**metrics, "improved_from": str(plan.policy), "improve_round": round_},
        )
        policy = load_policy(str(checkpoint))
        report.final_loss = _number(metrics, "final_loss")
        report.demo_accuracy = _number(metrics, "demo_accuracy")
        report.training_samples = int(_number(metrics, "training_samples"))
        report.train_seconds = _number(metrics, "train_seconds")
        report.checkpoint = str(checkpoint)
        report.seconds = time.perf_counter() - round_started
        reports.append(report)
        if progress is not None:
            progress.write(report.line(plan.rounds) + "\n")
            progress.flush()
    return {
        "improved_from": str(plan.policy),
        "task_file": plan.task_file_name,
        "rounds": [r.to_dict() for r in reports],
        "labels": sum(r.labels for r in reports),
        "demos": [str(p) for p in student.demos],
        "labels_files": [str(p) for p in labelled],
        "seconds": round(time.perf_counter() - started, 2),
    }


def _number(metrics: dict[str, object], key: str) -> float:
    """A numeric training metric (the trainer's metrics are a JSON-ready table)."""
    value = metrics[key]
    if not isinstance(value, int | float):
        raise TypeError(f"training metric {key!r} is not a number: {value!r}")
    return float(value)
