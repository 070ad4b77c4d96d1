"""GNN policy inference latency: Scene -> Decision, graph build included.

Stack layout: K blocks in one tower and K block goals in another tower, randomly initialised
weights (latency does not depend on training). Target: p50 <= 2 ms at K = 40 (80 nodes,
6320 edges) on one CPU thread.

    .venv/bin/python bench/bench_policy_inference.py [--iterations 300] [--rounds 3]

Timed: ``GNNPolicy.decide``, which runs the network's dense path for one complete graph
(``PolicyNet.forward_complete``). For comparison, "mp best" times the same decision through
PyG message passing over the edge index (``PolicyNet.forward``, what the explainer and the
trainer's reference "pyg" batch layout run, and what ``decide`` ran before the dense path);
"speed-up" is their ratio.

glibc malloc note: at K = 40 message passing's per-edge tensors are ~1.6 MB; with glibc's
default dynamic mmap/trim thresholds they can be returned to the OS and page-faulted back on
every call, which roughly doubles its latency depending on what ran before. Compare with
``MALLOC_MMAP_THRESHOLD_=16777216 MALLOC_TRIM_THRESHOLD_=134217728`` in the environment. The
dense path's largest tensor is the N x N attention matrix (25 kB at K = 40).

p50/p99 are over all rounds; "best p50" is the lowest per-round median, the usual estimate of
the cost on an unloaded machine (other processes only ever add time).
"""

from __future__ import annotations

import argparse
import statistics
import time
import warnings
from collections.abc import Callable
from functools import partial

import torch

warnings.filterwarnings("ignore", category=FutureWarning)  # torch.jit.script, from PyG import

from scenes import stack_scene  # noqa: E402  (bench/scenes.py)

from manigraph_planner.gnn import ARCHITECTURES, ModelConfig, PolicyNet, scene_to_graph  # noqa: E402
from manigraph_planner.policies.base import Decision  # noqa: E402
from manigraph_planner.policies.gnn import GNNPolicy, decision_from_logits  # noqa: E402
from manigraph_shared.messages import Scene  # noqa: E402

TARGET_MS = 2.0


def percentiles_ms(samples_ns: list[int]) -> tuple[float, float]:
    ordered = sorted(samples_ns)
    p99 = ordered[min(len(ordered) - 1, round(0.99 * (len(ordered) - 1)))]
    return statistics.median(ordered) / 1e6, p99 / 1e6


def time_call(call: Callable[[], object], iterations: int) -> list[int]:
    for _ in range(max(20, iterations // 10)):  # warm-up: allocator, PyG caches
        call()
    samples = []
    for _ in range(iterations):
        start = time.perf_counter_ns()
        call()
        samples.append(time.perf_counter_ns() - start)
    return samples


def decide_by_message_passing(policy: GNNPolicy, scene: Scene) -> Decision | None:
    """``policy.decide(scene)`` with PyG message passing over the explicit edge index."""
    graph = scene_to_graph(scene)
    with torch.inference_mode():
        logits = policy.net(graph.x, graph.edge_index)
    return decision_from_logits(graph, logits)


def best_p50_ms(call: Callable[[], object], iterations: int, rounds: int) -> float:
    return min(percentiles_ms(time_call(call, iterations))[0] for _ in range(rounds))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--iterations", type=int, default=300, help="timed calls per round")
    parser.add_argument("--rounds", type=int, default=3)
    parser.add_argument("--blocks", type=int, nargs="+", default=[3, 9, 40])
    args = parser.parse_args()

    torch.manual_seed(0)
    scenes = {k: stack_scene(k) for k in args.blocks}
    print(
        f"torch {torch.__version__}, 1 thread (set by GNNPolicy), "
        f"{args.rounds} rounds x {args.iterations} calls, times in ms"
    )
    header = (
        f"{'arch':<6} {'K':>3} {'nodes':>5} {'build p50':>9} {'p50 ms':>7} {'p99 ms':>7}"
        f" {'best p50':>8} {'mp best':>7} {'speed-up':>8}  p50 / {TARGET_MS:g} ms"
    )
    print(header)
    print("-" * len(header))
    for arch in sorted(ARCHITECTURES):
        policy = GNNPolicy(PolicyNet(ModelConfig(arch)))
        for k, scene in scenes.items():
            build, _ = percentiles_ms(time_call(partial(scene_to_graph, scene), args.iterations))
            rounds = [
                time_call(partial(policy.decide, scene), args.iterations)
                for _ in range(args.rounds)
            ]
            p50, p99 = percentiles_ms([t for samples in rounds for t in samples])
            best = min(percentiles_ms(samples)[0] for samples in rounds)
            message_passing = best_p50_ms(
                partial(decide_by_message_passing, policy, scene), args.iterations, args.rounds
            )
            ratio = p50 / TARGET_MS
            print(
                f"{arch:<6} {k:>3} {2 * k:>5} {build:>9.3f} {p50:>7.3f} {p99:>7.3f}"
                f" {best:>8.3f} {message_passing:>7.3f} {message_passing / best:>7.1f}x"
                f"  {ratio:.2f}x"
            )


if __name__ == "__main__":
    main()
