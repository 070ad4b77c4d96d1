"""The comparison's report: Markdown table, success-vs-K plot, explainer top-2 features."""

from __future__ import annotations

import json
from importlib.metadata import PackageNotFoundError, version
from pathlib import Path
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from manigraph_lab.rl.compare import CompareSpec, RunStore

__all__ = ["explain_top_features", "markdown_table", "plot", "write_report"]

#: The paper's numbers (section "Comparisons on K-Block stacking").
PAPER = {
    "rl-mlp": "0.45 ± 0.01 at K=3; collapses for K ≥ 6",
    "rl-gnn": "0.57 ± 0.03 at K=3; collapses for K ≥ 6",
    "rl-gnn-seq": "0.67 ± 0.03 at K=3; collapses for K ≥ 6",
    "rl-gnn-demo": "not substantially better than RL-GNN-Seq",
    "il": "0.85-1.0 at K=9",
}

TITLES = {
    "rl-mlp": "RL-MLP",
    "rl-gnn": "RL-GNN",
    "rl-gnn-seq": "RL-GNN-Seq",
    "rl-gnn-demo": "RL-GNN-demo",
}


def title(method: str) -> str:
    if method.startswith("il-"):
        return f"IL-GNN ({method[3:]})"
    return TITLES.get(method, method)


def _version(package: str) -> str:
    try:
        return version(package)
    except PackageNotFoundError:
        return "?"


def markdown_table(spec: CompareSpec, results: dict[str, Any]) -> str:
    settings = spec.settings
    ks = [str(k) for k in settings.blocks]
    stages = len(settings.blocks)
    lines = [
        "# RL baselines against imitation on K-block stacking",
        "",
        f"Success rate (every goal filled) over {spec.episodes} episodes per K (layout seeds "
        f"0-{spec.episodes - 1}). RL rows: mean ± std over training seeds "
        f"{', '.join(map(str, spec.seeds))}; IL rows: the shipped checkpoint (one policy, "
        "trained on 20 box pack/unpack demonstrations of K = 3, 4).",
        "",
        f"**Budget**: PPO (sb3-contrib {_version('sb3-contrib')} MaskablePPO, "
        f"stable-baselines3 {_version('stable-baselines3')}), "
        f"{settings.steps_per_stage:,} environment interactions per stage, {stages} stages: "
        f"{settings.steps_per_stage * stages:,} per baseline and training seed (RL-MLP: "
        f"{settings.steps_per_stage:,} per K, one policy per K). PPO n_steps "
        f"{settings.n_steps}, batch {settings.batch_size}, {settings.n_epochs} epochs, lr "
        f"{settings.learning_rate}, entropy {settings.ent_coef}; GNN {settings.architecture} "
        f"{settings.num_layers} x {settings.hidden_channels} (MLP the same widths); "
        f"RL-GNN-demo λ_IL = {settings.imitation_weight} on the 20 expert demonstrations.",
        "",
        "| method | " + " | ".join(f"K={k}" for k in ks) + " | paper |",
        "|---|" + "---|" * (len(ks) + 1),
    ]
    for method, row in results["methods"].items():
        cells = []
        for k in ks:
            if k not in row["mean"]:
                cells.append("-")
            elif row["kind"] == "il":
                cells.append(f"{row['mean'][k]:.2f}")
            else:
                cells.append(f"{row['mean'][k]:.2f} ± {row['std'][k]:.2f}")
        paper = PAPER.get("il" if row["kind"] == "il" else method, "")
        lines.append(f"| {title(method)} | " + " | ".join(cells) + f" | {paper} |")
    explain = results.get("explain")
    if explain:
        lines += [
            "",
            f"## What the policies attend to ({explain['blocks']}-block stacking)",
            "",
            f"Explainer (manigraph_planner.explain) over {explain['decisions']} decisions per "
            "policy: the feature most often ranked first, then second (paper: RL-GNN-Seq "
            'attends almost only to "z"; IL also to "filled", which the paper calls unfilled).',
            "",
            "| policy | top-2 features | first-ranked counts | second-ranked counts | "
            "episode success |",
            "|---|---|---|---|---|",
        ]
        for name, cell in explain["policies"].items():
            lines.append(
                f"| {name} | {cell['top2']} | {_counts(cell['top1_counts'])} | "
                f"{_counts(cell['top2_counts'])} | {cell['success_rate']:.2f} |"
            )
    return "\n".join(lines) + "\n"


def _counts(counts: dict[str, int]) -> str:
    return ", ".join(f"{k} {v}" for k, v in counts.items()) or "-"


def plot(spec: CompareSpec, results: dict[str, Any], path: Path) -> None:
    """Success rate against K, one line per method (the paper's Figure
    "full_comparison_blockstacking"); RL lines with a ± std band, IL lines dashed."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    figure, axes = plt.subplots(figsize=(9, 4))
    for method, row in results["methods"].items():
        ks = sorted(int(k) for k in row["mean"])
        means = [row["mean"][str(k)] for k in ks]
        if row["kind"] == "il":
            axes.plot(ks, means, "--", marker=".", label=title(method))
            continue
        stds = [row["std"][str(k)] for k in ks]
        (line,) = axes.plot(ks, means, marker="o", label=title(method))
        low = [max(m - s, 0.0) for m, s in zip(means, stds, strict=True)]
        high = [min(m + s, 1.0) for m, s in zip(means, stds, strict=True)]
        axes.fill_between(ks, low, high, color=line.get_color(), alpha=0.2)
    axes.set_xlabel("K (blocks)")
    axes.set_ylabel("success rate")
    axes.set_ylim(-0.02, 1.02)
    axes.set_xticks(list(spec.settings.blocks))
    axes.set_title(
        f"K-block stacking: PPO, {spec.settings.steps_per_stage:,} interactions per K, "
        f"{len(spec.seeds)} seeds"
    )
    axes.grid(alpha=0.3)
    axes.legend(fontsize=8, loc="center left", bbox_to_anchor=(1.01, 0.5))
    figure.tight_layout()
    figure.savefig(path, dpi=120)
    plt.close(figure)


def explain_top_features(spec: CompareSpec, store: RunStore) -> dict[str, Any] | None:
    """The explainer's top-2 features of RL-GNN-Seq (its K = ``explain_blocks`` stage, first
    seed) and of the IL checkpoint of the same architecture, over ``explain_decisions``
    decisions of ``explain_blocks``-block stacking (cached in ``explain.json``)."""
    from manigraph_lab.explanation_study import cell_text, collect_explanations, summarise
    from manigraph_lab.rl.baselines import BASELINES, load_model
    from manigraph_planner.policies import load_policy

    baseline = BASELINES["rl-gnn-seq"]
    stage = next(
        (s for s in baseline.stages(spec.settings) if s.blocks == (spec.explain_blocks,)), None
    )
    if "rl-gnn-seq" not in spec.baselines or stage is None:
        return None
    seed = spec.seeds[0]
    path = spec.out / "explain.json"
    key = {
        "decisions": spec.explain_decisions,
        "blocks": spec.explain_blocks,
        "seed": seed,
        "model": store.digest(baseline.name, seed, stage),
        "il_checkpoints": [str(c) for c in spec.il_checkpoints],
    }
    if path.is_file():
        cached: dict[str, Any] = json.loads(path.read_text())
        if {k: cached.get(k) for k in key} == key:
            return cached
    env = baseline.make_env(stage, spec.settings)
    model = load_model(store.model(baseline.name, seed, stage), env)
    policies = {f"RL-GNN-Seq (seed {seed}, stage {stage.name})": baseline.policy(model, env)}
    same = [c for c in spec.il_checkpoints if c.stem == spec.settings.architecture]
    for checkpoint in same or list(spec.il_checkpoints)[:1]:
        policies[f"IL-GNN ({checkpoint.stem})"] = load_policy(str(checkpoint))
    cells: dict[str, Any] = {}
    for name, policy in policies.items():
        explanations, episodes, successes = collect_explanations(
            policy, spec.explain_decisions, task="stack", blocks=spec.explain_blocks, stacks=1
        )
        cell = summarise(explanations)
        cell["top2"] = cell_text(cell)
        cell["success_rate"] = successes / max(episodes, 1)
        cells[name] = cell
    result = {**key, "policies": cells}
    path.write_text(json.dumps(result, indent=2) + "\n")
    return result


def write_report(spec: CompareSpec, results: dict[str, Any]) -> None:
    spec.out.mkdir(parents=True, exist_ok=True)
    (spec.out / "table.md").write_text(markdown_table(spec, results))
    plot(spec, results, spec.out / "success_vs_k.png")
    summary = {
        "spec": {
            "baselines": list(spec.baselines),
            "seeds": list(spec.seeds),
            "episodes": spec.episodes,
            "il_checkpoints": [str(p) for p in spec.il_checkpoints],
            "settings": spec.settings.to_dict(),
        },
        **results,
    }
    (spec.out / "results.json").write_text(json.dumps(summary, indent=2) + "\n")
