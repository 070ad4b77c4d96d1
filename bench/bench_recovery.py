"""What a refused decision costs an episode, in the geometric world (in process, fast).

Cases that refuse (``object_covered``): the shipped GAT checkpoint on a 10-block pyramid and
on a 4 x 4 multistack (it picks covered blocks), and on the 6-level size tower of
examples/tasks/unwritten/ judged by its rules (issue 51: hundreds of ``object_covered`` in
50 episodes). Per case:

* ``refusals``: failed skills by reason (``{reason: count}``);
* ``recovered``: refusals after which a later decision of the episode succeeded, and
  ``median_extra_steps``: the median over them of the decisions from the refusal up to (not
  counting) the next one that succeeded: 1 when the very next decision succeeds.
  Target: <= 1 (issue 51);
* ``refused_again_unchanged``: refusals of a pair refused before in the episode for the same
  reason, with the world the same (every object within 5 mm, the same goals filled) when the
  two were decided. Target: 0;
* ``out_of_options``: episodes that ended because every option left was refused.

It runs whatever code it is imported with: for the figures before a change, run it from a
worktree of the earlier commit (docs/recovery.md):

    python3 -m uv run --frozen --all-packages python bench/bench_recovery.py [--episodes 50]

One line per case and a JSON summary with the load average (the figures are counts and do
not depend on load).
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import time
from collections import Counter
from pathlib import Path

import manigraph_planner
from manigraph_lab.episode_loop import EpisodeRecord, run_episode
from manigraph_lab.evaluate import EvalSpec
from manigraph_planner.policies import load_policy
from manigraph_planner.recovery import ProgressMonitor

REPO = Path(__file__).resolve().parents[1]
#: Seeds drawn for this bench only (nothing else in the repository uses 881000-881999).
SEED = 881000
TOWER = REPO / "examples" / "tasks" / "unwritten" / "size-tower-6"


def cases(episodes: int) -> dict[str, tuple[str, EvalSpec]]:
    gat = str(REPO / "checkpoints" / "gat.pt")
    return {
        "gat pyramid-10": (gat, EvalSpec("pyramid", 10, episodes=episodes, seed=SEED)),
        "gat multistack-4x4": (gat, EvalSpec("multistack", 4, 4, episodes=episodes, seed=SEED)),
        "gat size-tower-6 (rules)": (
            gat,
            EvalSpec(
                "file",
                6,
                episodes=episodes,
                seed=SEED,
                task_file=TOWER.with_suffix(".toml").read_text(),
                task_file_name="size-tower-6",
                rules=TOWER.with_suffix(".rules.toml").read_text(),
            ),
        ),
    }


def measure(records: list[EpisodeRecord]) -> dict[str, object]:
    same = ProgressMonitor()
    refusals: Counter[str] = Counter()
    extra: list[int] = []
    again = 0
    for record in records:
        steps = record.steps
        for i, step in enumerate(steps):
            if step.ok:
                continue
            reason = step.reason or "unknown"
            refusals[reason] += 1
            pair = (step.action.object_id, step.action.goal_id)
            if any(
                (e.action.object_id, e.action.goal_id) == pair
                and e.reason == step.reason
                and same.same_world(e.scene, step.scene)
                for e in steps[:i]
                if not e.ok
            ):
                again += 1
            later = next((j for j in range(i + 1, len(steps)) if steps[j].ok), None)
            if later is not None:
                extra.append(later - i)
    ended = [r for r in records if r.end.reason.startswith("out_of_options")]
    return {
        "episodes": len(records),
        "success_rate": sum(r.success for r in records) / max(len(records), 1),
        "mean_steps": statistics.fmean(len(r.steps) for r in records) if records else 0.0,
        "refusals": dict(refusals.most_common()),
        "recovered": len(extra),
        "median_extra_steps": statistics.median(extra) if extra else None,
        "mean_extra_steps": round(statistics.fmean(extra), 3) if extra else None,
        "refused_again_unchanged": again,
        "out_of_options": len(ended),
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--episodes", type=int, default=50)
    args = parser.parse_args()
    commit = subprocess.run(
        ["git", "rev-parse", "--short", "HEAD"], capture_output=True, text=True, check=False
    ).stdout.strip()
    results: dict[str, object] = {}
    started = time.perf_counter()
    for name, (policy_spec, spec) in cases(args.episodes).items():
        policy = load_policy(policy_spec)
        records = [run_episode(policy, request) for request in spec.requests()]
        figures = measure(records)
        results[name] = figures
        refused = figures["refusals"]
        assert isinstance(refused, dict)
        print(
            f"{name:>26}: success {figures['success_rate']:.2f}, "
            f"refusals {sum(refused.values())}, "
            f"median extra steps {figures['median_extra_steps']}, "
            f"refused again unchanged {figures['refused_again_unchanged']}, "
            f"out of options {figures['out_of_options']}",
            flush=True,
        )
    summary = {
        "commit": commit,
        "code": str(Path(manigraph_planner.__file__).resolve().parents[3]),
        "seed": SEED,
        "cases": results,
        "seconds": round(time.perf_counter() - started, 1),
        "load_average": [round(x, 2) for x in os.getloadavg()],
    }
    print(json.dumps(summary))


if __name__ == "__main__":
    main()
