"""Robot cells on one planner: aggregate decisions/s and per-cell decision latency, beside one
cell alone in the same run.

    .venv/bin/python bench/bench_cells.py [--cells 8] [--blocks 9] [--episodes 20]
        [--policy checkpoints/sage.pt] [--planner-per-cell]

Starts ``manigraph up --cells N --policy P`` (N geometric cells, each its own sim and skills,
one planner for all; ``--planner-per-cell``: one planner process per cell, to compare), then:

1. warm-up: one episode in every cell at once (first torch calls, publishers declared);
2. **alone**: ``--episodes`` episodes in cell-1 while the other cells idle;
3. **together**: ``--episodes`` episodes in every cell at once (cell-1 on the seeds of step 2).

Decision latency is "scene published -> Action received": the Action's arrival time at this
process minus the ``stamp`` of the scene it was decided on (``scene_sequence``; the sim stamps a
scene with ``time.time()`` as it publishes it, same clock). It covers the scene's trip to the
planner, any wait for the previous skill's final status, the GNN decision and the Action's trip
back. Throughput is a cell's decisions over the phase's wall time.

Targets (issue 29): per-cell p50 <= 2x the single-cell p50; min cell throughput >= 0.8x mean.
A last section times ``decide`` on the loaded policy in 1 and in N threads at once (the same
scene; every thread must get the serial answer) to show whether a shared policy needs a lock
or batching. Last line: one JSON object ``{"bench": "cells", ...}``.
"""

from __future__ import annotations

import argparse
import contextlib
import io
import json
import os
import signal
import statistics
import subprocess
import sys
import tempfile
import threading
import time
from dataclasses import replace
from pathlib import Path

from scenes import stack_scene  # bench/scenes.py

from manigraph_shared.bus import Bus
from manigraph_shared.bus_config import BusConfig
from manigraph_shared.cells import cell_names
from manigraph_shared.messages import Action, Scene
from manigraph_testkit.testing import free_port
from manigraph_tools.cell_episodes import run_cells
from manigraph_tools.episode_plan import EpisodeOptions
from manigraph_tools.episodes import run_episodes

P50_RATIO_TARGET = 2.0
STARVATION_TARGET = 0.8


class Observer:
    """Every cell's scenes and actions as they arrive; latencies by phase and cell, matched
    once the phase is over (an Action may overtake its scene on the way here)."""

    def __init__(self, buses: dict[str, Bus]) -> None:
        self.phase = "warm-up"
        self._stamps: dict[tuple[str, str, int], float] = {}
        self._actions: list[tuple[str, str, tuple[str, str, int], float]] = []
        self._lock = threading.Lock()
        for cell, bus in buses.items():
            bus.subscribe(Scene, lambda scene, cell=cell: self._on_scene(cell, scene))
            bus.subscribe(Action, lambda action, cell=cell: self._on_action(cell, action))

    def _on_scene(self, cell: str, scene: Scene) -> None:
        with self._lock:
            self._stamps[(cell, scene.episode_id, scene.sequence)] = scene.stamp

    def _on_action(self, cell: str, action: Action) -> None:
        arrived = time.time()
        with self._lock:
            scene = (cell, action.episode_id, action.scene_sequence)
            self._actions.append((self.phase, cell, scene, arrived))

    def of(self, phase: str, cell: str) -> list[float]:
        """Seconds from each decided scene's stamp to its Action's arrival."""
        with self._lock:
            return [
                arrived - self._stamps[scene]
                for p, c, scene, arrived in self._actions
                if p == phase and c == cell and scene in self._stamps
            ]

    @property
    def unmatched(self) -> int:
        """Actions whose scene never arrived here (a scene is dropped under congestion)."""
        with self._lock:
            return sum(scene not in self._stamps for _, _, scene, _ in self._actions)


def cpu_by_service(parent: int) -> dict[str, float]:
    """CPU seconds (user + system) each service of ``manigraph up`` (pid ``parent``) has used,
    summed over its cells' processes: where the machine's time goes."""
    tick = os.sysconf("SC_CLK_TCK")
    used: dict[str, float] = {}
    for stat in Path("/proc").glob("[0-9]*/stat"):
        try:
            fields = stat.read_text().rsplit(")", 1)[1].split()
            argv = (stat.parent / "cmdline").read_bytes().split(b"\0")
        except OSError:  # gone meanwhile
            continue
        if int(fields[1]) != parent or b"manigraph_shared.cli" not in argv:
            continue
        service = argv[argv.index(b"manigraph_shared.cli") + 1].decode()
        used[service] = used.get(service, 0.0) + (int(fields[11]) + int(fields[12])) / tick
    return used


def percentile_ms(samples: list[float], q: float) -> float:
    ordered = sorted(samples)
    return 1000 * ordered[min(len(ordered) - 1, round(q * (len(ordered) - 1)))]


def figures(samples: list[float], seconds: float) -> dict[str, float]:
    return {
        "decisions": len(samples),
        "decisions_per_s": round(len(samples) / seconds, 1),
        "p50_ms": round(1000 * statistics.median(samples), 2),
        "p99_ms": round(percentile_ms(samples, 0.99), 2),
    }


def start_stack(args: argparse.Namespace, port: int, log_dir: Path) -> subprocess.Popen[str]:
    argv = [
        *(sys.executable, "-m", "manigraph_shared.cli", "up"),
        *("--cells", str(args.cells), "--policy", args.policy, "--task", "stack"),
        *("--blocks", str(args.blocks), "--port", str(port), "--log-dir", str(log_dir)),
        *(["--planner-per-cell"] if args.planner_per_cell else []),
    ]
    up = subprocess.Popen(argv, stderr=subprocess.PIPE, stdout=subprocess.DEVNULL, text=True)
    assert up.stderr is not None
    deadline = time.monotonic() + 300
    for line in up.stderr:  # until the stack says it is up
        if "stack is up" in line:
            threading.Thread(target=up.stderr.read, daemon=True).start()  # keep draining
            return up
        if time.monotonic() > deadline:
            break
    up.kill()
    raise SystemExit(f"manigraph up did not come up (exit {up.poll()}); logs in {log_dir}")


def decide_in_threads(policy_path: str, blocks: int, threads: int, calls: int) -> dict:
    """``decide`` per-call p50 on one thread and on ``threads`` at once, and whether every
    concurrent call got the serial decision."""
    from manigraph_planner.policies import load_policy

    policy = load_policy(policy_path)
    scene = stack_scene(blocks)
    expected = policy.decide(scene)

    def timed(count: int, out: list[float], wrong: list[int]) -> None:
        for _ in range(count):
            start = time.perf_counter()
            if policy.decide(scene) != expected:
                wrong.append(1)
            out.append(time.perf_counter() - start)

    alone: list[float] = []
    timed(calls, alone, [])
    together: list[list[float]] = [[] for _ in range(threads)]
    wrong: list[int] = []
    workers = [
        threading.Thread(target=timed, args=(calls, together[i], wrong)) for i in range(threads)
    ]
    started = time.perf_counter()
    for worker in workers:
        worker.start()
    for worker in workers:
        worker.join()
    wall = time.perf_counter() - started
    every = [t for samples in together for t in samples]
    return {
        "threads": threads,
        "p50_ms_one_thread": round(1000 * statistics.median(alone), 3),
        "p50_ms_concurrent": round(1000 * statistics.median(every), 3),
        "calls_per_s_one_thread": round(len(alone) / sum(alone), 1),
        "calls_per_s_concurrent": round(len(every) / wall, 1),
        "wrong_decisions": len(wrong),
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--cells", type=int, default=8)
    parser.add_argument("--blocks", type=int, default=9)
    parser.add_argument("--episodes", type=int, default=20, help="per cell and phase")
    parser.add_argument("--policy", default="checkpoints/sage.pt")
    parser.add_argument("--planner-per-cell", action="store_true")
    parser.add_argument("--seed", type=int, default=100)
    args = parser.parse_args()

    load_before = os.getloadavg()
    port = free_port()
    log_dir = Path(tempfile.mkdtemp(prefix="bench-cells-"))
    cells = cell_names(args.cells)
    options = EpisodeOptions(task="stack", blocks=args.blocks, seed=args.seed)
    quiet = io.StringIO()  # the runs' progress lines: not the bench's output
    started = time.monotonic()
    up = start_stack(args, port, log_dir)
    print(
        f"stack up in {time.monotonic() - started:.1f} s: {args.cells} geometric cells, "
        f"{'a planner per cell' if args.planner_per_cell else 'one planner'}, "
        f"{args.policy}, stack K = {args.blocks}",
        file=sys.stderr,
    )
    client = BusConfig(connect=(f"tcp/127.0.0.1:{port}",), wait_seconds=60.0)
    summaries: dict[str, dict] = {}
    seconds: dict[str, float] = {}
    try:
        with contextlib.ExitStack() as stack:
            buses = {c: stack.enter_context(Bus.open(replace(client, cell=c))) for c in cells}
            observer = Observer(buses)
            run_cells(buses, options.plan(1, run_id="warm"), quiet)
            observer.phase = "alone"
            begun = time.monotonic()
            summaries["alone"] = run_episodes(
                buses[cells[0]], options.plan(args.episodes, run_id="alone"), quiet
            )
            seconds["alone"] = time.monotonic() - begun
            observer.phase = "together"
            cpu_before = cpu_by_service(up.pid)
            begun = time.monotonic()
            summaries["together"] = run_cells(
                buses, options.plan(args.episodes, run_id="together"), quiet
            )
            seconds["together"] = time.monotonic() - begun
            cpu_after = cpu_by_service(up.pid)
    finally:
        up.send_signal(signal.SIGINT)
        try:
            up.wait(timeout=60)
        except subprocess.TimeoutExpired:
            up.kill()
    load_after = os.getloadavg()

    alone = figures(observer.of("alone", cells[0]), seconds["alone"])
    per_cell = {c: figures(observer.of("together", c), seconds["together"]) for c in cells}
    rates = [f["decisions_per_s"] for f in per_cell.values()]
    worst_p50 = max(f["p50_ms"] for f in per_cell.values())
    p50_ratio = worst_p50 / alone["p50_ms"]
    starvation = min(rates) / statistics.mean(rates)
    threads = decide_in_threads(args.policy, args.blocks, args.cells, 300)
    decisions = sum(f["decisions"] for f in per_cell.values())
    cpu_ms = {  # per decision, while every cell ran
        service: round(1000 * (cpu_after[service] - cpu_before.get(service, 0.0)) / decisions, 2)
        for service in sorted(cpu_after)
    }

    print(f"{'':<10} {'decisions':>9} {'dec/s':>7} {'p50 ms':>7} {'p99 ms':>7}")
    print(
        f"{'alone':<10} {alone['decisions']:>9} {alone['decisions_per_s']:>7}"
        f" {alone['p50_ms']:>7} {alone['p99_ms']:>7}"
    )
    for cell, f in per_cell.items():
        print(
            f"{cell:<10} {f['decisions']:>9} {f['decisions_per_s']:>7}"
            f" {f['p50_ms']:>7} {f['p99_ms']:>7}"
        )
    print(
        f"together: {sum(rates):.1f} decisions/s in {seconds['together']:.1f} s; worst cell p50 "
        f"{p50_ratio:.2f}x alone (target <= {P50_RATIO_TARGET:g}x); min/mean throughput "
        f"{starvation:.2f} (target >= {STARVATION_TARGET:g}); success "
        f"{summaries['together']['success_rate']} (alone {summaries['alone']['success_rate']})"
    )
    print(
        f"decide on {args.cells} threads at once: p50 {threads['p50_ms_concurrent']} ms/call "
        f"vs {threads['p50_ms_one_thread']} ms alone; {threads['calls_per_s_concurrent']} vs "
        f"{threads['calls_per_s_one_thread']} calls/s; {threads['wrong_decisions']} wrong"
    )
    print(
        "CPU per decision, together (ms, summed over the service's processes): "
        + ", ".join(f"{service} {ms}" for service, ms in cpu_ms.items())
    )
    print(f"load average before {load_before[0]:.2f}, after {load_after[0]:.2f}; logs {log_dir}")
    result = {
        "bench": "cells",
        "cells": args.cells,
        "blocks": args.blocks,
        "policy": args.policy,
        "planner": "per-cell" if args.planner_per_cell else "shared",
        "episodes_per_cell": args.episodes,
        "alone": alone,
        "together": per_cell,
        "aggregate_decisions_per_s": round(sum(rates), 1),
        "p50_ratio_worst_cell": round(p50_ratio, 2),
        "min_over_mean_throughput": round(starvation, 2),
        "targets_met": p50_ratio <= P50_RATIO_TARGET and starvation >= STARVATION_TARGET,
        "success_rate": {
            "alone": summaries["alone"]["success_rate"],
            "together": summaries["together"]["success_rate"],
        },
        "unmatched_actions": observer.unmatched,
        "decide_threads": threads,
        "cpu_ms_per_decision": cpu_ms,
        "load": [round(load_before[0], 2), round(load_after[0], 2)],
        "date": time.strftime("%Y-%m-%d"),
    }
    print(json.dumps(result))


if __name__ == "__main__":
    main()
