"""``manigraph rl-compare``: train the RL baselines, evaluate them beside the IL checkpoints.

Everything lands under ``out`` and is reused on a rerun, so an interrupted comparison resumes
where it stopped:

* ``runs/<baseline>/seed<s>/<stage>.zip`` and ``<stage>.json`` — each finished stage's model
  and record (the record holds the settings; a rerun with other settings is refused);
* ``runs/<baseline>/seed<s>/eval.json`` and ``il/<checkpoint>.json`` — evaluations;
* ``demos.mcap`` — RL-GNN-demo's expert demonstrations (``manigraph demos``' protocol);
* ``results.json``, ``table.md``, ``success_vs_k.png``, ``explain.json`` — the report
  (:mod:`manigraph_lab.rl.report`).
"""

from __future__ import annotations

import hashlib
import io
import json
import statistics
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from functools import cache
from pathlib import Path
from typing import Any

from tqdm import tqdm

from manigraph_lab.evaluate import EvalSpec, evaluate
from manigraph_lab.rl.baselines import BASELINES, Baseline, PPOSettings, Stage, train_stage
from manigraph_planner.policies.base import Policy
from manigraph_shared.errors import ConfigError
from manigraph_training.dataset import Sample

__all__ = ["CompareSpec", "RunStore", "run_comparison"]


@dataclass(frozen=True)
class CompareSpec:
    """What ``rl-compare`` runs. Raises ``ConfigError`` naming the field."""

    out: Path = Path("results/rl")
    baselines: tuple[str, ...] = ("rl-mlp", "rl-gnn", "rl-gnn-seq", "rl-gnn-demo")
    seeds: tuple[int, ...] = (0, 1, 2)
    episodes: int = 50
    il_checkpoints: tuple[Path, ...] = ()
    explain_decisions: int = 100
    explain_blocks: int = 5
    settings: PPOSettings = field(default_factory=PPOSettings)

    def __post_init__(self) -> None:
        unknown = [b for b in self.baselines if b not in BASELINES]
        if unknown:
            raise ConfigError(
                "baselines", f"unknown {unknown[0]!r} (known: {', '.join(sorted(BASELINES))})"
            )
        if not self.seeds or min(self.seeds) < 0 or len(set(self.seeds)) != len(self.seeds):
            raise ConfigError("seeds", f"need distinct seeds >= 0, got {self.seeds}")
        if self.episodes < 1:
            raise ConfigError("episodes", f"must be >= 1, got {self.episodes}")
        if self.explain_decisions < 0:
            raise ConfigError("explain_decisions", f"must be >= 0, got {self.explain_decisions}")
        for path in self.il_checkpoints:
            if not path.is_file():
                raise ConfigError("il_checkpoints", f"no such checkpoint file: {path}")


class RunStore:
    """Where each stage's model and record live, and whether a stage is finished."""

    def __init__(self, out: Path, settings: PPOSettings) -> None:
        self.out = out
        self.settings = settings

    def folder(self, baseline: str, seed: int) -> Path:
        return self.out / "runs" / baseline / f"seed{seed}"

    def model(self, baseline: str, seed: int, stage: Stage) -> Path:
        return self.folder(baseline, seed) / f"{stage.name}.zip"

    def record(self, baseline: str, seed: int, stage: Stage) -> Path:
        return self.folder(baseline, seed) / f"{stage.name}.json"

    def digest(self, baseline: str, seed: int, stage: Stage) -> str:
        """Identifies a saved stage model, so evaluations of an older one are not reused."""
        data = self.model(baseline, seed, stage).read_bytes()
        return hashlib.sha256(data).hexdigest()[:16]

    def finished(self, baseline: str, seed: int, stage: Stage) -> dict[str, Any] | None:
        """The stage's record if it finished with these settings; raises if it finished with
        others (the saved models would not be the ones asked for)."""
        record_path = self.record(baseline, seed, stage)
        if not (record_path.is_file() and self.model(baseline, seed, stage).is_file()):
            return None
        record: dict[str, Any] = json.loads(record_path.read_text())
        if record.get("settings") != self.settings.to_dict():
            raise ConfigError(
                "out",
                f"{record_path} was trained with other settings; "
                "use another --out or delete that run",
            )
        return record

    def save_record(self, baseline: str, seed: int, stage: Stage, record: dict[str, Any]) -> None:
        path = self.record(baseline, seed, stage)
        path.write_text(json.dumps({**record, "settings": self.settings.to_dict()}, indent=2))


def train_baseline(
    baseline: Baseline,
    seed: int,
    store: RunStore,
    demos: Callable[[], Sequence[Sample]],
    bar: tqdm | None = None,
) -> list[dict[str, Any]]:
    """Every stage of one baseline and seed, skipping the finished ones; their records."""
    records: list[dict[str, Any]] = []
    previous: Path | None = None
    for stage in baseline.stages(store.settings):
        record = store.finished(baseline.name, seed, stage)
        if record is None:
            if bar is not None:
                bar.set_postfix_str(f"{baseline.name} seed {seed} {stage.name}")
            start = previous if baseline.continues else None
            path = store.model(baseline.name, seed, stage)
            record = train_stage(baseline, stage, store.settings, seed, start, path, demos)
            store.save_record(baseline.name, seed, stage, record)
        records.append(record)
        previous = store.model(baseline.name, seed, stage)
        if bar is not None:
            bar.update(1)
    return records


def evaluate_baseline(
    baseline: Baseline, seed: int, store: RunStore, episodes: int
) -> dict[str, dict[str, float]]:
    """Success per K of a trained baseline (cached in ``eval.json``): each stage's policy at
    the K it is evaluated on."""
    from manigraph_lab.rl.baselines import load_model

    path = store.folder(baseline.name, seed) / "eval.json"
    models = {
        stage.name: store.digest(baseline.name, seed, stage)
        for stage in baseline.stages(store.settings)
        if stage.evaluate_on
    }
    if path.is_file():
        cached: dict[str, Any] = json.loads(path.read_text())
        if cached.get("episodes") == episodes and cached.get("models") == models:
            return dict(cached["per_k"])
    per_k: dict[str, dict[str, float]] = {}
    started = time.perf_counter()
    for stage in baseline.stages(store.settings):
        if not stage.evaluate_on:
            continue
        env = baseline.make_env(stage, store.settings)
        policy = baseline.policy(load_model(store.model(baseline.name, seed, stage), env), env)
        for k in stage.evaluate_on:
            per_k[str(k)] = _score(policy, k, episodes)
    seconds = round(time.perf_counter() - started, 2)
    path.write_text(
        json.dumps(
            {"episodes": episodes, "models": models, "seconds": seconds, "per_k": per_k},
            indent=2,
        )
    )
    return per_k


def evaluate_checkpoint(
    checkpoint: Path, blocks: Sequence[int], out: Path, episodes: int
) -> dict[str, dict[str, float]]:
    """Success per K of a shipped IL checkpoint (cached under ``out/il``)."""
    from manigraph_planner.policies import load_policy

    path = out / "il" / f"{checkpoint.stem}.json"
    digest = hashlib.sha256(checkpoint.read_bytes()).hexdigest()[:16]
    if path.is_file():
        cached: dict[str, Any] = json.loads(path.read_text())
        same = (cached.get("episodes"), cached.get("digest")) == (episodes, digest)
        if same and set(cached["per_k"]) >= {str(k) for k in blocks}:
            return {str(k): cached["per_k"][str(k)] for k in blocks}
    policy = load_policy(str(checkpoint))
    per_k = {str(k): _score(policy, k, episodes) for k in blocks}
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(
        json.dumps(
            {"checkpoint": str(checkpoint), "digest": digest, "episodes": episodes, "per_k": per_k},
            indent=2,
        )
    )
    return per_k


def _score(policy: Policy, blocks: int, episodes: int) -> dict[str, float]:
    summary = evaluate(policy, EvalSpec("stack", blocks, episodes=episodes), progress=None)
    return {
        "success_rate": float(summary["success_rate"]),  # type: ignore[arg-type]
        "goals_filled_rate": round(float(summary["goals_filled_rate"]), 4),  # type: ignore[arg-type]
    }


def demo_source(out: Path) -> Callable[[], Sequence[Sample]]:
    """The paper's 20 expert demonstrations (box pack/unpack, K = 3, 4), recorded once."""

    @cache
    def load() -> tuple[Sample, ...]:
        from manigraph_lab.demo_recording import DemoProtocol, record_demos
        from manigraph_planner.policies import load_policy
        from manigraph_training.dataset import load_demonstrations

        path = out / "demos.mcap"
        if not path.is_file():
            out.mkdir(parents=True, exist_ok=True)
            partial = path.with_suffix(".partial.mcap")
            record_demos(load_policy("expert"), DemoProtocol(), partial, progress=io.StringIO())
            partial.replace(path)
        return tuple(load_demonstrations([path]).samples)

    return load


def run_comparison(spec: CompareSpec, show_progress: bool = True) -> dict[str, Any]:
    """Train, evaluate and explain; write the report under ``spec.out``; return its numbers."""
    from manigraph_lab.rl.report import explain_top_features, write_report

    store = RunStore(spec.out, spec.settings)
    demos = demo_source(spec.out)
    baselines = [BASELINES[name] for name in spec.baselines]
    units = sum(len(b.stages(spec.settings)) + 1 for b in baselines) * len(spec.seeds)
    units += len(spec.il_checkpoints) + (1 if spec.explain_decisions else 0)
    results: dict[str, Any] = {"methods": {}, "training": {}}
    with tqdm(total=units, disable=not show_progress, unit="stage") as bar:
        for baseline in baselines:
            per_seed: dict[str, Any] = {}
            for seed in spec.seeds:
                records = train_baseline(baseline, seed, store, demos, bar)
                bar.set_postfix_str(f"{baseline.name} seed {seed} eval")
                per_seed[str(seed)] = evaluate_baseline(baseline, seed, store, spec.episodes)
                bar.update(1)
                results["training"][f"{baseline.name}/seed{seed}"] = records
            results["methods"][baseline.name] = _aggregate(per_seed, kind="rl")
        for checkpoint in spec.il_checkpoints:
            bar.set_postfix_str(f"IL {checkpoint.name}")
            per_k = evaluate_checkpoint(checkpoint, spec.settings.blocks, spec.out, spec.episodes)
            results["methods"][f"il-{checkpoint.stem}"] = _aggregate({"-": per_k}, kind="il")
            bar.update(1)
        if spec.explain_decisions:
            bar.set_postfix_str("explainer")
            results["explain"] = explain_top_features(spec, store)
            bar.update(1)
    write_report(spec, results)
    return results


def _aggregate(per_seed: dict[str, dict[str, dict[str, float]]], kind: str) -> dict[str, Any]:
    """Mean ± std over seeds of the success rate at each K (std 0 for a single run)."""
    ks = sorted({int(k) for scores in per_seed.values() for k in scores})
    mean, std = {}, {}
    for k in ks:
        rates = [scores[str(k)]["success_rate"] for scores in per_seed.values()]
        mean[str(k)] = round(statistics.fmean(rates), 4)
        std[str(k)] = round(statistics.pstdev(rates), 4) if len(rates) > 1 else 0.0
    return {"kind": kind, "mean": mean, "std": std, "per_seed": per_seed}
