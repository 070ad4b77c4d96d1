"""``manigraph suite``: the paper's experiments for every architecture over several seeds.

Trains one policy per (architecture, seed) on the default protocol (or reuses the checkpoint
already in ``<out>/checkpoints``), evaluates each on the cells of the paper's Table
"generalization" plus this project's targets, and writes:

* ``<out>/generalization.md`` — success rate mean ± std over seeds, one row per architecture;
* ``<out>/success_vs_k.png`` — K-block stacking success for K = 2..40 (paper Fig.
  "full_comparison_blockstacking");
* ``<out>/suite.json`` — every number, per seed.
"""

from __future__ import annotations

import json
import statistics
from dataclasses import dataclass, replace
from pathlib import Path
from typing import TextIO

from manigraph_lab.demos import DemoProtocol, record_demos
from manigraph_lab.evaluate import EvalSpec, success_rate
from manigraph_planner.policies import load_policy
from manigraph_shared.progress import Progress


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


def checkpoint_for(
    out: Path, demos: Path, arch: str, seed: int, epochs: int, progress: TextIO | None = None
) -> Path:
    path = out / "checkpoints" / f"{arch}-seed{seed}.pt"
    if path.exists():
        return path
    from manigraph_planner.gnn import save_checkpoint
    from manigraph_planner.training.dataset import load_demonstrations
    from manigraph_planner.training.trainer import TrainConfig, train

    data = load_demonstrations([demos])
    config = TrainConfig(architecture=arch, seed=seed, epochs=epochs)
    net, metrics = train(data, config, progress)
    path.parent.mkdir(parents=True, exist_ok=True)
    return save_checkpoint(
        path, net, training_config=config.to_dict(), data_hash=data.data_hash, metrics=metrics
    )


def run_suite(
    out: Path,
    archs: list[str],
    seeds: list[int],
    episodes: int,
    curve_episodes: int,
    epochs: int,
    progress: TextIO | None = None,
    eval_seed: int = 0,
) -> dict[str, object]:
    """Fill the table and the curve (none with ``curve_episodes`` 0); the table's episodes
    start at ``eval_seed`` (the reported figures: 0; validation while choosing a recipe:
    1000+). ``progress``: stream for bars (drawn on a terminal only) and one line per cell."""
    out.mkdir(parents=True, exist_ok=True)
    demos = out / "demos.mcap"
    if not demos.exists():
        record_demos(load_policy("expert"), DemoProtocol(), demos, progress)
    table = [replace(c, spec=replace(c.spec, seed=eval_seed)) for c in cells(episodes)]
    curve_k = CURVE_K if curve_episodes > 0 else ()
    results: dict[str, dict[str, list[float]]] = {}
    curves: dict[str, dict[int, list[float]]] = {}
    # One unit per checkpoint trained or loaded, per table cell and per point of the curve.
    work = len(archs) * len(seeds) * (1 + len(table) + len(curve_k))
    bar = Progress(work, "suite", unit="step", stream=progress)
    for arch in archs:
        results[arch] = {cell.label: [] for cell in table}
        curves[arch] = {k: [] for k in curve_k}
        for seed in seeds:
            bar.status(f"{arch} seed {seed}")
            checkpoint = checkpoint_for(out, demos, arch, seed, epochs, progress)
            policy = load_policy(str(checkpoint))
            bar.update()
            for cell in table:
                rate = success_rate(policy, cell.spec, progress)
                results[arch][cell.label].append(rate)
                bar.note(f"{arch} seed {seed}: {cell.label}: {rate:.3f}")
                bar.update()
            for k in curve_k:
                spec = EvalSpec("stack", k, episodes=curve_episodes, seed=10_000)
                curves[arch][k].append(success_rate(policy, spec, progress))
                bar.update()
    bar.close()
    (out / "generalization.md").write_text(markdown(table, results, seeds, episodes, eval_seed))
    if curve_k:
        plot(curves, out / "success_vs_k.png", len(seeds), curve_episodes)
    summary = {
        "seeds": seeds,
        "eval_seed": eval_seed,
        "episodes": episodes,
        "results": results,
        "curves": {a: {str(k): v for k, v in c.items()} for a, c in curves.items()},
    }
    (out / "suite.json").write_text(json.dumps(summary, indent=1))
    return summary


def _mean_std(values: list[float]) -> str:
    """Mean ± std, and the worst seed when there are several: a recipe is only as good as
    the seed a user happens to train."""
    if len(values) == 1:
        return f"{values[0]:.3f} ± 0.000"
    return (
        f"{statistics.fmean(values):.3f} ± {statistics.pstdev(values):.3f} (min {min(values):.2f})"
    )


def markdown(
    table: list[Cell],
    results: dict[str, dict[str, list[float]]],
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


def plot(curves: dict[str, dict[int, list[float]]], path: Path, seeds: int, episodes: int) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    figure, axes = plt.subplots(figsize=(7, 4))
    for arch, by_k in curves.items():
        ks = sorted(by_k)
        means = [statistics.fmean(by_k[k]) for k in ks]
        stds = [statistics.pstdev(by_k[k]) if len(by_k[k]) > 1 else 0.0 for k in ks]
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
