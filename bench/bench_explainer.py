"""Explainer latency and the "top edges touch the chosen object" rate.

1. Latency: one explanation (the modified GNNExplainer with its default steps, one CPU
   thread), Scene -> Explanation, for K = 3, 9, 40 stacking scenes (K blocks in one tower, K
   goals in another). Target: p50 <= 250 ms at K = 9.
2. Touch rate (``--touch-decisions N``, default 100): the policy runs seeded episodes of a task
   in process (default: the paper's 3-block 3-stack), every decision is explained, and we count
   how often every kept edge starts or ends on the chosen object (the paper: always), how
   often the top edge does, and how often at least one kept edge touches the chosen object or
   goal. 0 skips it.

    .venv/bin/python bench/bench_explainer.py [--checkpoints checkpoints/*.pt] [--iterations 20]

Without checkpoints (or if one is missing) the latency uses a randomly initialised network:
latency does not depend on training; the touch rate does, so it needs a checkpoint.
"""

from __future__ import annotations

import argparse
import statistics
import time
import warnings
from pathlib import Path

import torch

warnings.filterwarnings("ignore", category=FutureWarning)  # torch.jit.script, from PyG import

from scenes import stack_scene  # noqa: E402  (bench/scenes.py)

from manigraph_lab.explanation_study import collect_explanations, edges_touch_object  # noqa: E402
from manigraph_planner.explain import ExplainerConfig, SceneExplainer  # noqa: E402
from manigraph_planner.gnn import ModelConfig, PolicyNet  # noqa: E402
from manigraph_planner.policies.gnn import GNNPolicy  # noqa: E402

TARGET_MS = 250.0
ROOT = Path(__file__).resolve().parents[1]


def policy_for(arch_or_path: str) -> GNNPolicy:
    path = Path(arch_or_path)
    if path.suffix == ".pt":
        return GNNPolicy.from_checkpoint(path)
    torch.manual_seed(0)
    return GNNPolicy(PolicyNet(ModelConfig(arch_or_path)))


def latency(policy: GNNPolicy, blocks: list[int], iterations: int, steps: int) -> None:
    explainer = SceneExplainer(policy, ExplainerConfig(steps=steps))
    for k in blocks:
        scene = stack_scene(k)
        for seed in range(2):  # warm-up
            explainer.explain_scene(scene, seed)
        times = []
        for seed in range(iterations):
            start = time.perf_counter()
            explainer.explain_scene(scene, seed)
            times.append((time.perf_counter() - start) * 1e3)
        times.sort()
        p50 = statistics.median(times)
        p90 = times[min(len(times) - 1, round(0.9 * (len(times) - 1)))]
        print(
            f"{policy.name:<10} {k:>3} {2 * k:>5} {2 * k * (2 * k - 1):>6} {p50:>8.1f}"
            f" {p90:>8.1f}  {p50 / TARGET_MS:.2f}x"
        )


def touch_rate(policy: GNNPolicy, count: int, task: str, blocks: int, stacks: int) -> None:
    started = time.perf_counter()
    explanations, episodes, successes = collect_explanations(policy, count, task, blocks, stacks)
    n = max(len(explanations), 1)
    every = sum(map(edges_touch_object, explanations)) / n
    top = sum(e.object in (e.edges[0].src, e.edges[0].dst) for e in explanations) / n
    either = (
        sum(
            any({e.object, e.goal} & {edge.src, edge.dst} for edge in e.edges) for e in explanations
        )
        / n
    )
    features = statistics.mode(next(iter(e.features)) for e in explanations)
    success = successes / max(episodes, 1)
    print(
        f"{policy.name:<10} {len(explanations):>9} {episodes:>8} {success:>7.2f}"
        f" {every:>9.2f} {top:>8.2f} {either:>10.2f} {features:>8}"
        f"   ({time.perf_counter() - started:.0f} s)"
    )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    default = [str(ROOT / "checkpoints" / f"{a}.pt") for a in ("gcn", "sage", "gated", "gat")]
    parser.add_argument("--checkpoints", nargs="+", default=default, help="files or arch names")
    parser.add_argument("--iterations", type=int, default=20, help="timed explanations per K")
    parser.add_argument("--blocks", type=int, nargs="+", default=[3, 9, 40])
    parser.add_argument("--steps", type=int, default=ExplainerConfig().steps)
    parser.add_argument("--touch-decisions", type=int, default=100)
    parser.add_argument("--task", default="multistack")
    parser.add_argument("--task-blocks", type=int, default=3)
    parser.add_argument("--task-stacks", type=int, default=3)
    args = parser.parse_args()

    policies = []
    for spec in args.checkpoints:
        if spec.endswith(".pt") and not Path(spec).is_file():
            print(f"(no {spec}: using a random {Path(spec).stem} network for latency)")
            spec = Path(spec).stem
        policies.append(policy_for(spec))
    print(f"torch {torch.__version__}, 1 thread, {args.steps} steps, {args.iterations} runs per K")
    header = (
        f"{'policy':<10} {'K':>3} {'nodes':>5} {'edges':>6} {'p50 ms':>8} {'p90 ms':>8}"
        f"  p50 / {TARGET_MS:g} ms"
    )
    print(header)
    print("-" * len(header))
    for policy in policies:
        latency(policy, args.blocks, args.iterations, args.steps)
    if args.touch_decisions <= 0:
        return
    print()
    print(f"top edges vs chosen object, {args.task} K={args.task_blocks} s={args.task_stacks}")
    header = (
        f"{'policy':<10} {'decisions':>9} {'episodes':>8} {'success':>7} {'all-touch':>9}"
        f" {'top-edge':>8} {'obj-or-goal':>10} {'top feat':>8}"
    )
    print(header)
    print("-" * len(header))
    for policy in policies:
        if policy.info is None:
            continue  # a random network's explanations say nothing about the task
        touch_rate(policy, args.touch_decisions, args.task, args.task_blocks, args.task_stacks)


if __name__ == "__main__":
    main()
