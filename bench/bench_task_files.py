"""Teach a task written only as a task file, and score it at twice the objects (issue #43).

For each example task of ``examples/tasks/`` (a task of the block family written only as
task files: a small file and larger ones) the bench runs, as a user types them (a new process
each, imports included):

1. ``manigraph demos --task-file SMALL --trajectories 20 --seed 0 -o DEMOS``  (seeds 0-19)
2. ``manigraph train DEMOS --arch sage --seed 0 -o MODEL``
3. ``manigraph eval --policy MODEL --task-file LARGE --episodes 50 --seed 2000 --json``
   (seeds 2000-2049: used for nothing else, neither training nor tuning)

and prints a table: success and wrong-object goals at the larger size, and the wall time of
each step with "teach to run" (their sum; target <= 120 s on the 2-core machine). The load
average is printed beside it: take timings with nothing else running. Not a test.

**The baseline beside every learned figure** (issue #49): the same network trained on the
same demonstrations for 1 epoch (``--epochs 1``: untrained, loss ~2) is scored on the same
episodes, with the accepts filter on (what a user gets) and off (``--accepts-filter off``:
the network's own choice). Where the baseline's success is within ``--margin`` (default
0.10) of the learned policy's, the row says ``no learning``: the filter, not the
demonstrations, made the figure.

    uv run python bench/bench_task_files.py                       # every example
    uv run python bench/bench_task_files.py --example size-sort   # one
    uv run python bench/bench_task_files.py --example unwritten/colour-place \
        --trajectories 10 --seeds 0 1 2 --arch gat               # a rule nobody wrote

The ``unwritten/`` examples (issue #49) are demonstrated and judged by their rules file
(``--rules``), which the policy never sees; their success counts only if the rule held.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

TASKS = Path(__file__).resolve().parents[1] / "examples" / "tasks"
#: example task -> (the file demonstrated, the files evaluated: twice the objects and more).
EXAMPLES = {
    "size-sort": ("size-sort.toml", ("size-sort-8.toml", "size-sort-12.toml")),
    "colour-sort": ("colour-sort.toml", ("colour-sort-8.toml",)),
    "kitting": ("kitting.toml", ("kitting-6.toml",)),
    "red-tower": ("red-tower.toml", ("red-tower-8.toml",)),
}
#: Rules nobody wrote (issue #49): the task file has no rule, ``<file>.rules.toml`` beside it
#: is what the teacher (demos) and the judge (eval) follow, never the policy.
UNWRITTEN = {
    f"unwritten/{name}": (f"unwritten/{name}.toml", tuple(f"unwritten/{name}-{n}.toml" for n in ns))
    for name, ns in (
        ("colour-place", (8, 12)),
        ("same-colour", (8, 12)),
        ("red-only-tower", (8, 12)),
        ("flat-back", (8, 12)),
        ("size-tower", (6, 9)),
    )
}
EXAMPLES.update(UNWRITTEN)


def rules_of(task_file: str) -> list[str]:
    """``--rules R`` for an unwritten example's file, else nothing."""
    rules = TASKS / task_file.replace(".toml", ".rules.toml")
    return ["--rules", str(rules)] if task_file.startswith("unwritten/") else []


def manigraph(*args: str) -> tuple[float, str]:
    started = time.perf_counter()
    result = subprocess.run(
        [sys.executable, "-m", "manigraph_shared.cli", *args],
        capture_output=True,
        text=True,
        timeout=1800,
        env={**os.environ, "MANIGRAPH_LOG_LEVEL": "WARNING"},
    )
    seconds = time.perf_counter() - started
    if result.returncode != 0:
        raise SystemExit(f"manigraph {' '.join(args)} failed:\n{result.stderr[-2000:]}")
    return seconds, result.stdout


def verdict(learned: float, baseline: float, margin: float) -> str:
    """``no learning`` where the 1-epoch baseline scores within ``margin`` of the learned."""
    return "no learning" if baseline >= learned - margin else "learned"


def score(model: Path, evaluated: str, episodes: int, accepts_filter: str) -> tuple[float, dict]:
    seconds, stdout = manigraph(
        "eval", "--policy", str(model), "--task-file", str(TASKS / evaluated),
        *rules_of(evaluated), "--episodes", str(episodes), "--seed", "2000", "--json",
        *(["--accepts-filter", "off"] if accepts_filter == "off" else []),
    )  # fmt: skip
    return seconds, json.loads(stdout.strip().splitlines()[-1])


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--example", choices=sorted(EXAMPLES), action="append")
    parser.add_argument("--episodes", type=int, default=50, help="evaluation episodes per file")
    parser.add_argument("--arch", default="sage", help="GNN architecture (default sage)")
    parser.add_argument(
        "--margin",
        type=float,
        default=0.10,
        help="a baseline within this much of the learned success: no learning (default 0.10)",
    )
    parser.add_argument("--trajectories", type=int, default=20, help="demonstrations (20)")
    parser.add_argument(
        "--seeds", type=int, nargs="+", default=[0], help="training seeds, a row each (0)"
    )
    parser.add_argument("--train-args", default="", help="more train flags, e.g. '--grow 8'")
    args = parser.parse_args()
    rows = []
    with tempfile.TemporaryDirectory(prefix="bench-task-files-") as scratch:
        out = Path(scratch)
        for example, seed in ((e, s) for e in args.example or list(EXAMPLES) for s in args.seeds):
            small, large = EXAMPLES[example]
            name = example.replace("/", "-")
            demos, model = out / f"{name}.mcap", out / f"{name}-{seed}.pt"
            baseline = out / f"{name}-{seed}-1-epoch.pt"
            t_demos = 0.0
            if not demos.exists():
                t_demos, _ = manigraph(
                    "demos", "--task-file", str(TASKS / small), *rules_of(small),
                    "--trajectories", str(args.trajectories), "--seed", "0", "-o", str(demos),
                )  # fmt: skip
            train = ["train", str(demos), "--arch", args.arch, "--seed", str(seed)]
            train += args.train_args.split()  # the baseline is the same network: same flags
            t_train, _ = manigraph(*train, "-o", str(model))
            manigraph(*train, "--epochs", "1", "-o", str(baseline))
            # A file without accepts has no filter to turn off: scored once.
            filters = ("on",) if example in UNWRITTEN else ("on", "off")
            for index, evaluated in enumerate(large):
                for accepts_filter in filters:
                    t_eval, summary = score(model, evaluated, args.episodes, accepts_filter)
                    _, base = score(baseline, evaluated, args.episodes, accepts_filter)
                    teach = t_demos + t_train + t_eval
                    first = index == 0 and accepts_filter == "on"
                    row = {
                        "example": example,
                        "seed": seed,
                        "demonstrated": small,
                        "evaluated": evaluated,
                        "accepts_filter": accepts_filter,
                        "success": summary["success_rate"],
                        "baseline_1_epoch": base["success_rate"],
                        "verdict": verdict(
                            summary["success_rate"], base["success_rate"], args.margin
                        ),
                        "wrong_object": summary.get("wrong_object", 0),
                        "rule_violations": summary.get("rule_violations"),
                        "baseline_rule_violations": base.get("rule_violations"),
                        "demos_s": round(t_demos, 1),
                        "train_s": round(t_train, 1),
                        "eval_s": round(t_eval, 1),
                        "teach_to_run_s": round(teach, 1) if first else None,
                        "load": round(os.getloadavg()[0], 2),
                    }
                    rows.append(row)
                    print(json.dumps(row), file=sys.stderr, flush=True)
    print(
        f"| example | seed | evaluated | filter | success | 1-epoch baseline "
        f"| (margin {args.margin:.2f}) | wrong object | rule violations | demos s | train s "
        "| eval s | teach to run s | load |"
    )
    print("|---|---|---|---|---|---|---|---|---|---|---|---|---|---|")
    for r in rows:
        teach = "-" if r["teach_to_run_s"] is None else f"{r['teach_to_run_s']:.1f}"
        print(
            f"| {r['example']} | {r['seed']} | {r['evaluated']} | {r['accepts_filter']} "
            f"| {r['success']:.2f} | {r['baseline_1_epoch']:.2f} | {r['verdict']} "
            f"| {r['wrong_object']} | {r['rule_violations']} | {r['demos_s']:.1f} "
            f"| {r['train_s']:.1f} "
            f"| {r['eval_s']:.1f} | {teach} | {r['load']:.2f} |"
        )
    print(json.dumps({"rows": rows}))
    return 0


if __name__ == "__main__":
    sys.exit(main())
