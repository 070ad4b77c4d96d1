"""The paper's Table 'dishwasher', reproduced (``manigraph dishwasher-experiment``).

For each preference: record 5 expert demonstrations of the 5-plate, 5-bowl task through the
demo recorder (MCAP), train the four-headed policy with 3 seeds, and evaluate each on 6, 8, 10
and 12 dishes; write the table (Markdown and JSON, mean ± std over the seeds) and a plot.
The seed-0 network (an ensemble of the recipe's members) of each preference is also kept as a
checkpoint.
"""

from __future__ import annotations

import json
import multiprocessing
import statistics
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any, TextIO

from manigraph_dishwasher.preference import Preference

PREFERENCES = tuple(preference.value for preference in Preference)
#: The paper's protocol: 5 demonstrations of 10 dishes, tested on 6, 8, 10 and 12.
TRAIN_OBJECTS = 10
TEST_OBJECTS = (6, 8, 10, 12)
#: Evaluation seeds start here, far from the demonstrations' (0..4).
EVAL_SEED = 10_000


@dataclass(frozen=True)
class ExperimentConfig:
    out: Path
    architecture: str = "sage"
    seeds: tuple[int, ...] = (0, 1, 2)
    demos: int = 5
    episodes: int = 100
    epochs: int = 300
    checkpoints: Path | None = Path("checkpoints")
    #: (preference, seed) runs at once, each in its own process.
    jobs: int = 1


def run_experiment(config: ExperimentConfig, log: TextIO | None = None) -> dict[str, object]:
    """Record, train and evaluate every (preference, seed); ``config.jobs`` runs of them at
    once, each in its own process (the results do not depend on it)."""
    # Imported here: every ``manigraph`` command loads this module to build its parser, and
    # torch with PyG takes seconds (minutes on a loaded machine) to import.
    from manigraph_dishwasher.training.loop import DishTrainConfig
    from manigraph_lab.demo_recording import DemoProtocol, record_demos

    config.out.mkdir(parents=True, exist_ok=True)
    started = time.perf_counter()
    runs = []
    for preference in PREFERENCES:
        demo_path = config.out / f"demos-{preference}.mcap"
        protocol = DemoProtocol(("dishwasher",), (4,), config.demos, 0, TRAIN_OBJECTS, preference)
        record_demos(None, protocol, demo_path)  # the family's expert of ``preference``
        runs += [(config, preference, demo_path, seed) for seed in config.seeds]
    table: dict[str, dict[int, list[float]]] = {
        p: {n: [] for n in TEST_OBJECTS} for p in PREFERENCES
    }
    if config.jobs > 1:
        context = multiprocessing.get_context("spawn")
        with context.Pool(min(config.jobs, len(runs))) as pool:
            results = pool.starmap(_train_and_evaluate, runs)
    else:
        results = [_train_and_evaluate(*run) for run in runs]
    for (_, preference, _, seed), rates in zip(runs, results, strict=True):
        for n, rate in rates.items():
            table[preference][n].append(rate)
            if log is not None:
                log.write(f"{preference} seed {seed} objects {n}: {rate:.2f}\n")
                log.flush()
    summary = {
        "architecture": config.architecture,
        "members_per_seed": DishTrainConfig().members,
        "seeds": list(config.seeds),
        "demos": config.demos,
        "train_objects": TRAIN_OBJECTS,
        "episodes_per_cell": config.episodes,
        "seconds": round(time.perf_counter() - started, 1),
        "success": {
            p: {str(n): {"mean": _mean(r), "std": _std(r), "runs": r} for n, r in rows.items()}
            for p, rows in table.items()
        },
    }
    (config.out / "table.json").write_text(json.dumps(summary, indent=2) + "\n")
    (config.out / "table.md").write_text(markdown_table(summary))
    plot(summary, config.out / "success.png")
    return summary


def _train_and_evaluate(
    config: ExperimentConfig, preference: str, demo_path: Path, seed: int
) -> dict[int, float]:
    """One training seed of one preference (the recipe's members, :class:`DishTrainConfig`):
    its success rate for each number of dishes (and the checkpoint, for the first seed)."""
    import torch

    from manigraph_dishwasher.planner.gnn_policy import DishwasherGNNPolicy
    from manigraph_dishwasher.training.loop import (
        DishTrainConfig,
        load_dish_demonstrations,
        train_dish,
    )
    from manigraph_lab.evaluate import EvalSpec, evaluate
    from manigraph_planner.gnn import save_checkpoint

    torch.set_num_threads(1)
    demos = load_dish_demonstrations([demo_path])
    train = DishTrainConfig(config.architecture, seed, config.epochs)
    net, metrics = train_dish(demos, train)
    if seed == config.seeds[0] and config.checkpoints is not None:
        config.checkpoints.mkdir(parents=True, exist_ok=True)
        save_checkpoint(
            config.checkpoints / f"dishwasher-{preference}-{config.architecture}.pt",
            net,
            training_config={**train.to_dict(), "demos": config.demos},
            data_hash=demos.data_hash,
            metrics=metrics,
        )
    policy = DishwasherGNNPolicy(net)
    rates = {}
    for n in TEST_OBJECTS:
        spec = EvalSpec(
            "dishwasher",
            4,
            episodes=config.episodes,
            seed=EVAL_SEED,
            objects=n,
            preference=preference,
        )
        rates[n] = float(evaluate(policy, spec)["success_rate"])  # type: ignore[arg-type]
    return rates


def _mean(values: list[float]) -> float:
    return round(statistics.fmean(values), 3)


def _std(values: list[float]) -> float:
    return round(statistics.pstdev(values), 3) if len(values) > 1 else 0.0


def markdown_table(summary: dict[str, Any]) -> str:
    header = "| Scenario | " + " | ".join(f"{n} objects" for n in TEST_OBJECTS) + " |"
    lines = [header, "|---|" + "---|" * len(TEST_OBJECTS)]
    names = {"top-bottom": "Top/bottom", "left-right": "Left/right"}
    for preference, row in summary["success"].items():
        cells = [f"{row[str(n)]['mean']:.2f} ± {row[str(n)]['std']:.2f}" for n in TEST_OBJECTS]
        lines.append(f"| {names[preference]} | " + " | ".join(cells) + " |")
    members = summary.get("members_per_seed", 1)
    ensemble = f" (ensembles of {members} per seed)" if members > 1 else ""
    note = (
        f"\n{summary['architecture']}{ensemble}, {summary['demos']} demonstrations of "
        f"{summary['train_objects']} dishes, seeds {summary['seeds']}, "
        f"{summary['episodes_per_cell']} episodes per cell.\n"
    )
    return "\n".join(lines) + "\n" + note


def plot(summary: dict[str, Any], path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    figure, axes = plt.subplots(figsize=(5, 3.2))
    for preference, row in summary["success"].items():
        means = [row[str(n)]["mean"] for n in TEST_OBJECTS]
        stds = [row[str(n)]["std"] for n in TEST_OBJECTS]
        axes.errorbar(TEST_OBJECTS, means, yerr=stds, marker="o", capsize=3, label=preference)
    axes.axvline(TRAIN_OBJECTS, color="grey", linestyle=":", label="trained on")
    axes.set_xlabel("dishes")
    axes.set_ylabel("success rate")
    axes.set_ylim(0, 1.05)
    axes.set_xticks(list(TEST_OBJECTS))
    axes.legend(loc="lower left")
    axes.set_title(f"Dishwasher loading ({summary['architecture']}, 5 demos)")
    figure.tight_layout()
    figure.savefig(path, dpi=120)
    plt.close(figure)
