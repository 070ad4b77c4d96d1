"""``manigraph suite``: the paper's experiments for every architecture over several seeds.

Trains one policy per (architecture, seed) on the default protocol (or reuses the checkpoint
already in ``<out>/checkpoints``), evaluates each on the cells of the paper's Table
"generalization" plus this project's targets, and writes:

* ``<out>/generalization.md`` — success rate mean ± std over seeds, one row per architecture;
* ``<out>/success_vs_k.png`` — K-block stacking success for K = 2..40 (paper Fig.
  "full_comparison_blockstacking");
* ``<out>/suite.json`` — every number, per seed.

Each training and each (checkpoint, cell) evaluation is one job of a sweep
(:mod:`manigraph_lab.sweep`): Ray tasks by default, or sequentially in this process; the
figures are the same either way. ``suite --seeds 0 1 2 3 4`` is the seed study.
"""

from __future__ import annotations

import json
import statistics
import tempfile
from dataclasses import dataclass, replace
from pathlib import Path
from typing import TextIO

from manigraph_lab.demo_recording import DemoProtocol, record_demos
from manigraph_lab.evaluate import EvalSpec, success_rate
from manigraph_lab.sweep import (
    Job,
    Needs,
    Outcome,
    SweepError,
    SweepOptions,
    check_reachable,
    run_jobs,
)
from manigraph_planner.policies import load_policy
from manigraph_shared.progress import Progress
from manigraph_shared.results import checkpoint_field, rounded


@dataclass(frozen=True)
class Cell:
    label: str
    spec: EvalSpec
    paper: str


def cells(episodes: int) -> list[Cell]:
    return [
        Cell("K-block stacking, K=9", EvalSpec("stack", 9, episodes=episodes), "0.85-1.0"),
        Cell("K-block stacking, K=40", EvalSpec("stack", 40, episodes=episodes), "0.75 avg"),
        Cell("6-pyramid", EvalSpec("pyramid", 6, episodes=episodes), "1.0 (Gated 0.95)"),
        Cell("10-pyramid", EvalSpec("pyramid", 10, episodes=episodes), "-"),
        Cell("3-block 3-stack", EvalSpec("multistack", 3, 3, episodes=episodes), "0.6-1.0"),
        Cell("4-block 4-stack", EvalSpec("multistack", 4, 4, episodes=episodes), "-"),
        Cell(
            "box rearrangement (K=4)",
            EvalSpec("box-rearrangement", 4, episodes=episodes),
            "0.20-0.96",
        ),
        Cell(
            "6-block stacking, 2 cm noise",
            EvalSpec("stack", 6, episodes=episodes, noise=0.02),
            "1.0 (hardware)",
        ),
    ]


CURVE_K = (2, 3, 4, 6, 9, 12, 16, 20, 25, 30, 35, 40)


def train_cell(demos: bytes, arch: str, seed: int, epochs: int) -> bytes:
    """One (architecture, seed) policy trained on ``demos`` (an MCAP file's bytes); the
    checkpoint file's bytes. Seeded by ``seed`` alone, wherever it runs."""
    from manigraph_planner.gnn import save_checkpoint
    from manigraph_training.dataset import load_demonstrations
    from manigraph_training.trainer import TrainConfig, train

    with tempfile.TemporaryDirectory(prefix="manigraph-train-") as tmp:
        demo_path = Path(tmp) / "demos.mcap"
        demo_path.write_bytes(demos)
        data = load_demonstrations([demo_path])
        config = TrainConfig(architecture=arch, seed=seed, epochs=epochs)
        net, metrics = train(data, config, None)
        path = save_checkpoint(
            Path(tmp) / f"{arch}-seed{seed}.pt",
            net,
            training_config=config.to_dict(),
            data_hash=data.data_hash,
            metrics=metrics,
        )
        return path.read_bytes()


def eval_cell(checkpoint: bytes, spec: EvalSpec) -> float:
    """The success rate on ``spec``'s seeded episodes of the policy in ``checkpoint`` (a
    checkpoint file's bytes)."""
    with tempfile.TemporaryDirectory(prefix="manigraph-eval-") as tmp:
        path = Path(tmp) / "policy.pt"
        path.write_bytes(checkpoint)
        policy = load_policy(str(path))
    return success_rate(policy, spec)


def checkpoint_path(out: Path, arch: str, seed: int) -> Path:
    return out / "checkpoints" / f"{arch}-seed{seed}.pt"


def suite_jobs(
    out: Path,
    demos: Path,
    archs: list[str],
    seeds: list[int],
    epochs: int,
    table: list[Cell],
    curve_k: tuple[int, ...],
    curve_episodes: int,
) -> list[Job]:
    """Per (architecture, seed): its training (none where ``<out>/checkpoints`` holds it),
    then one job per table cell and one per point of the curve, each needing the checkpoint."""
    jobs = []
    demo_bytes: bytes | None = None
    for arch in archs:
        for seed in seeds:
            name = f"{arch} seed {seed}"
            existing = checkpoint_path(out, arch, seed)
            checkpoint: object
            if existing.exists():
                checkpoint = existing.read_bytes()
            else:
                demo_bytes = demo_bytes or demos.read_bytes()
                jobs.append(Job(f"{name}: training", train_cell, (demo_bytes, arch, seed, epochs)))
                checkpoint = Needs(f"{name}: training")
            for cell in table:
                jobs.append(Job(f"{name}: {cell.label}", eval_cell, (checkpoint, cell.spec)))
            for k in curve_k:
                spec = EvalSpec("stack", k, episodes=curve_episodes, seed=10_000)
                jobs.append(Job(f"{name}: curve K={k}", eval_cell, (checkpoint, spec)))
    return jobs


def run_suite(
    out: Path,
    archs: list[str],
    seeds: list[int],
    episodes: int,
    curve_episodes: int,
    epochs: int,
    progress: TextIO | None = None,
    eval_seed: int = 0,
    sweep: SweepOptions | None = None,
) -> dict[str, object]:
    """Fill the table and the curve (none with ``curve_episodes`` 0); the table's episodes
    start at ``eval_seed`` (the reported figures: 0; validation while choosing a recipe:
    1000+). ``progress``: stream for bars (drawn on a terminal only) and one line per cell.
    ``sweep``: where the cells run (default: sequentially in this process).

    Raises:
        SweepError: some cells failed; the others' figures are written all the same (a failed
            cell is null in ``suite.json`` and left out of the table's mean).
    """
    sweep = sweep or SweepOptions(ray=False)
    check_reachable(sweep)  # before the demonstrations, which take minutes
    out.mkdir(parents=True, exist_ok=True)
    demos = out / "demos.mcap"
    if not demos.exists():
        record_demos(load_policy("expert"), DemoProtocol(), demos, progress)
    table = [replace(c, spec=replace(c.spec, seed=eval_seed)) for c in cells(episodes)]
    curve_k = CURVE_K if curve_episodes > 0 else ()
    jobs = suite_jobs(out, demos, archs, seeds, epochs, table, curve_k, curve_episodes)
    bar = Progress(len(jobs), "suite", unit="cell", stream=progress)

    def done(job: Job, outcome: Outcome) -> None:
        if job.fn is train_cell and outcome.ok:  # kept at once: a later failure keeps it
            _, arch, seed, _ = job.args
            path = checkpoint_path(out, arch, seed)
            path.parent.mkdir(parents=True, exist_ok=True)
            path.write_bytes(outcome.value)
        if job.fn is eval_cell:
            shown = f"{outcome.value:.3f}" if outcome.ok else f"failed ({outcome.error})"
            bar.note(f"{job.name}: {shown}")

    outcomes = dict(zip(jobs, run_jobs(jobs, sweep, bar, done), strict=True))
    bar.close()
    by_name = {job.name: outcome for job, outcome in outcomes.items()}
    results: dict[str, dict[str, list[float | None]]] = {}
    curves: dict[str, dict[int, list[float | None]]] = {}
    for arch in archs:
        results[arch] = {
            c.label: [by_name[f"{arch} seed {s}: {c.label}"].value for s in seeds] for c in table
        }
        curves[arch] = {
            k: [by_name[f"{arch} seed {s}: curve K={k}"].value for s in seeds] for k in curve_k
        }
    (out / "generalization.md").write_text(markdown(table, results, seeds, episodes, eval_seed))
    if curve_k:
        plot(curves, out / "success_vs_k.png", len(seeds), curve_episodes)
    failures = {job.name: o.error for job, o in outcomes.items() if o.error is not None}
    summary = {
        "seeds": seeds,
        "eval_seed": eval_seed,
        "episodes": episodes,
        "results": results,
        "curves": {a: {str(k): v for k, v in c.items()} for a, c in curves.items()},
        # Each (architecture, seed) policy by its file and SHA-256; a failed training has none.
        "checkpoints": {
            arch: {
                str(seed): field["checkpoint"]
                for seed in seeds
                if (field := checkpoint_field(checkpoint_path(out, arch, seed)))
            }
            for arch in archs
        },
        **({"failures": failures} if failures else {}),
    }
    (out / "suite.json").write_text(json.dumps(rounded(summary), indent=1))
    if failures:
        raise SweepError(failures, len(jobs))
    return summary


def _mean_std(seeds: list[float | None]) -> str:
    """Mean ± std, and the worst seed when there are several: a recipe is only as good as
    the seed a user happens to train. Failed cells (None) are counted apart."""
    values = [v for v in seeds if v is not None]
    failed = len(seeds) - len(values)
    if not values:
        return "failed"
    return _mean_std_of(values) + (f" ({failed} failed)" if failed else "")


def _mean_std_of(values: list[float]) -> str:
    if len(values) == 1:
        return f"{values[0]:.3f} ± 0.000"
    return (
        f"{statistics.fmean(values):.3f} ± {statistics.pstdev(values):.3f} (min {min(values):.2f})"
    )


def markdown(
    table: list[Cell],
    results: dict[str, dict[str, list[float | None]]],
    seeds: list[int],
    episodes: int,
    eval_seed: int = 0,
) -> str:
    head = "| architecture | " + " | ".join(c.label for c in table) + " |"
    lines = [
        f"Success rate, mean ± std (and the worst seed) over training seeds {seeds}, "
        f"{episodes} episodes per cell from seed {eval_seed} "
        "(trained on 20 expert box packing/unpacking demonstrations, K = 3, 4).",
        "",
        head,
        "|" + "---|" * (len(table) + 1),
        "| paper | " + " | ".join(c.paper for c in table) + " |",
    ]
    for arch, row in results.items():
        lines.append(f"| {arch} | " + " | ".join(_mean_std(row[c.label]) for c in table) + " |")
    return "\n".join(lines) + "\n"


def plot(
    curves: dict[str, dict[int, list[float | None]]], path: Path, seeds: int, episodes: int
) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    figure, axes = plt.subplots(figsize=(7, 4))
    for arch, by_k in curves.items():
        done = {k: [v for v in by_k[k] if v is not None] for k in by_k}
        ks = sorted(k for k in done if done[k])
        means = [statistics.fmean(done[k]) for k in ks]
        stds = [statistics.pstdev(done[k]) if len(done[k]) > 1 else 0.0 for k in ks]
        axes.errorbar(ks, means, yerr=stds, marker="o", capsize=3, label=arch)
    axes.set_xlabel("K (blocks)")
    axes.set_ylabel("success rate")
    axes.set_ylim(-0.05, 1.05)
    axes.set_title(f"K-block stacking, trained on K = 3, 4 ({seeds} seeds x {episodes} episodes)")
    axes.grid(alpha=0.3)
    axes.legend()
    figure.tight_layout()
    figure.savefig(path, dpi=120)
    plt.close(figure)
