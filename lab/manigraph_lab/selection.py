"""``manigraph select``: keep the best of several trained checkpoints, judged on validation
episodes that no reported figure uses.

Imitation from 20 demonstrations leaves much of a policy's behaviour on unseen scenes to
chance: on this project, training seeds of the same recipe range from 0.05 to 1.00 on K = 40
stacking. Selection is the usual remedy. Each candidate plays the suite's cells (see
:func:`manigraph_lab.generalization_suite.cells`) on episodes seeded from
:data:`VALIDATION_SEED` on (the suite and ``manigraph eval`` report seeds 0-99, the
success-vs-K curve 10,000 on), and the candidate with the highest mean success rate is copied
to the output, with every candidate's scores recorded in its ``metrics["selection"]``.

The suite's mean ± std over training seeds measures the *recipe*; a selected checkpoint is
one artifact of it, chosen knowing the kinds of tasks it will be tested on (not the episodes).
"""

from __future__ import annotations

import statistics
from dataclasses import dataclass, replace
from pathlib import Path
from typing import TextIO

from manigraph_lab.generalization_suite import Cell, cells, eval_cell
from manigraph_lab.sweep import (
    Job,
    Outcome,
    SweepError,
    SweepOptions,
    check_reachable,
    run_jobs,
)
from manigraph_shared.errors import ConfigError
from manigraph_shared.progress import Progress

#: First episode seed of validation episodes.
VALIDATION_SEED = 1000


@dataclass(frozen=True)
class Candidate:
    path: Path
    scores: dict[str, float]  # success rate per cell label

    @property
    def mean(self) -> float:
        return statistics.fmean(self.scores.values())


def validation_cells(episodes: int, seed: int = VALIDATION_SEED) -> list[Cell]:
    """The suite's cells, on ``episodes`` episodes seeded from ``seed``."""
    return [replace(c, spec=replace(c.spec, episodes=episodes, seed=seed)) for c in cells(episodes)]


def score(
    checkpoints: list[Path],
    table: list[Cell],
    progress: TextIO | None = None,
    sweep: SweepOptions | None = None,
) -> list[Candidate]:
    """Every candidate's success per cell, one sweep job per (candidate, cell); ``progress``:
    stream for bars (on a terminal only) and for one line per cell; ``sweep``: where the
    jobs run (default: sequentially in this process).

    Raises:
        ConfigError: a checkpoint is listed twice.
        SweepError: some cells failed (each named); the scored ones were printed.
    """
    sweep = sweep or SweepOptions(ray=False)
    check_reachable(sweep)
    repeated = sorted({str(p) for p in checkpoints if checkpoints.count(p) > 1})
    if repeated:
        raise ConfigError("checkpoints", f"listed more than once: {', '.join(repeated)}")
    jobs = [
        Job(f"{path.name} ({path}): {cell.label}", eval_cell, (path.read_bytes(), cell.spec))
        for path in checkpoints
        for cell in table
    ]
    bar = Progress(len(jobs), "select", unit="cell", stream=progress)

    def done(job: Job, outcome: Outcome) -> None:
        shown = f"{outcome.value:.3f}" if outcome.ok else f"failed ({outcome.error})"
        bar.note(f"  {job.name}: {shown}")

    outcomes = run_jobs(jobs, sweep, bar, done)
    bar.close()
    failures = {j.name: o.error for j, o in zip(jobs, outcomes, strict=True) if o.error}
    if failures:
        raise SweepError(failures, len(jobs))
    rates = iter(outcomes)
    return [
        Candidate(path, {cell.label: next(rates).value for cell in table}) for path in checkpoints
    ]


def best(candidates: list[Candidate]) -> Candidate:
    """Highest mean success; the earliest candidate among equals (``max`` keeps the first)."""
    return max(candidates, key=lambda c: c.mean)


def markdown(candidates: list[Candidate], chosen: Candidate, episodes: int, seed: int) -> str:
    labels = list(candidates[0].scores)
    lines = [
        f"Validation success rate, {episodes} episodes per cell seeded from {seed}; "
        f"kept: {chosen.path.name}.",
        "",
        "| candidate | " + " | ".join(labels) + " | mean |",
        "|" + "---|" * (len(labels) + 2),
    ]
    for c in candidates:
        mark = " (kept)" if c is chosen else ""
        row = " | ".join(f"{c.scores[label]:.3f}" for label in labels)
        lines.append(f"| {c.path.name}{mark} | {row} | {c.mean:.3f} |")
    return "\n".join(lines) + "\n"


def select_checkpoint(
    checkpoints: list[Path],
    output: Path,
    episodes: int = 30,
    seed: int = VALIDATION_SEED,
    progress: TextIO | None = None,
    sweep: SweepOptions | None = None,
) -> tuple[Candidate, str]:
    """Score ``checkpoints`` on validation episodes, write the best to ``output`` (its
    metrics extended with the selection) and return it with the Markdown table; ``sweep``:
    where the (candidate, cell) evaluations run (default: sequentially in this process)."""
    from manigraph_planner.gnn import load_checkpoint, save_checkpoint

    candidates = score(checkpoints, validation_cells(episodes, seed), progress, sweep)
    chosen = best(candidates)
    net, info = load_checkpoint(chosen.path)
    selection = {
        "validation_seed": seed,
        "episodes_per_cell": episodes,
        "candidates": {c.path.name: c.scores for c in candidates},
        "kept": chosen.path.name,
    }
    output.parent.mkdir(parents=True, exist_ok=True)
    save_checkpoint(
        output,
        net,
        training_config=info.training_config,
        data_hash=info.data_hash,
        metrics={**(info.metrics or {}), "selection": selection},
    )
    return chosen, markdown(candidates, chosen, episodes, seed)
