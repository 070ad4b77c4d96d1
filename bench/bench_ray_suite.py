"""``manigraph suite`` on Ray: the same cells with 1 worker and with 2, wall time, speed-up,
where the time goes, and what Ray leaves in ``/tmp/ray``.

    uv run python bench/bench_ray_suite.py [--archs gcn sage] [--seeds 0 1] [--epochs 40]
        [--episodes 20] [--workers 2]

Run it under ``uv run``, as the README runs ``manigraph suite``: that is where Ray, left to
itself, builds each session a virtual environment for its workers (7.5 GB in ``/tmp/ray``,
issue 51); the line ``driver under uv run`` says whether this run was.

Records a few expert demonstrations once (4 box pack/unpack runs), then runs the same suite
(per architecture and seed: one training, then the 8 table cells, no curve) twice, each in a
fresh output folder and a fresh local Ray (``ray.init(num_cpus=N)``, started inside the timed
run as ``manigraph suite`` does): once with 1 worker, once with ``--workers``. Each task runs
torch on 1 thread, so the two runs do the same work; only how many cells run at once differs.
The success rates of both runs must be identical (exit status 1 otherwise).

Where the time goes: Ray's fixed cost is timed apart (a session of N workers whose tasks
only import what a cell imports): ``ray.init``, the workers' first task (their start and
imports), ``ray.shutdown``. The cells' own work is the timed run less that fixed cost, and
its speed-up is printed beside the whole run's.

``/tmp/ray`` (``du -s``) is measured before the first run and after the last: a sweep must
leave it no larger (exit status 1 otherwise), and leave no ``manigraph-ray-*`` folder.

Target (issues 29 and 51): 2 workers >= 1.7x faster than 1 on this 2-core machine. The load
average before and after is printed: on a shared machine the second core may not be free.
Last line: one JSON object ``{"bench": "ray_suite", ...}``.
"""

from __future__ import annotations

import argparse
import importlib.metadata
import json
import os
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path

import psutil

from manigraph_lab.demo_recording import DemoProtocol, record_demos
from manigraph_lab.generalization_suite import cells as table_cells
from manigraph_lab.generalization_suite import run_suite
from manigraph_lab.ray_local import TEMP_PREFIX, temp_root
from manigraph_lab.sweep import SweepOptions, ray_session
from manigraph_planner.policies import load_policy

SPEEDUP_TARGET = 1.7
RAY_TMP = Path("/tmp/ray")


def du_kib(path: Path) -> int:
    """``du -s`` of ``path`` in KiB; 0 where it does not exist."""
    if not path.exists():
        return 0
    done = subprocess.run(["du", "-sk", str(path)], capture_output=True, text=True, check=False)
    return int(done.stdout.split()[0]) if done.stdout else 0


def under_uv_run() -> bool:
    """Whether an ancestor is ``uv run`` (what makes Ray build a worker environment)."""
    for parent in psutil.Process().parents():
        try:
            line = parent.cmdline()
        except (psutil.NoSuchProcess, psutil.AccessDenied):
            continue
        if len(line) > 1 and os.path.basename(line[0]) == "uv" and line[1] == "run":
            return True
    return False


def _import_a_cell() -> int:
    """A task that imports what a cell imports, as a worker's first task does."""
    import manigraph_lab.generalization_suite  # noqa: F401  (torch, the planner, the sim)

    return os.getpid()


def fixed_cost(workers: int) -> dict[str, float]:
    """Ray's own cost around a sweep of ``workers`` workers: ``ray.init``, the workers' first
    task (start-up and imports, all workers at once), ``ray.shutdown``."""
    started = time.perf_counter()
    with ray_session(SweepOptions(workers=workers, ray=True)) as ray:
        up = time.perf_counter()
        task = ray.remote(num_cpus=1)(_import_a_cell)
        pids = ray.get([task.remote() for _ in range(workers)])
        ready = time.perf_counter()
    down = time.perf_counter()
    assert len(set(pids)) == workers, pids
    return {
        "init_s": round(up - started, 2),
        "first_task_s": round(ready - up, 2),
        "shutdown_s": round(down - ready, 2),
        "total_s": round(down - started, 2),
    }


class CpuLedger(threading.Thread):
    """CPU seconds of this process and of everything it started (Ray's GCS, raylet and agents;
    its workers), sampled every ``interval`` s: what Ray's own processes cost beside the cells.
    A process's last ``interval`` before it exits is not counted."""

    RAYS_OWN = ("gcs_server", "raylet", "Agent", "log_monitor", "dashboard", "monitor.py")

    def __init__(self, interval: float = 0.5) -> None:
        super().__init__(daemon=True)
        self.interval = interval
        self.seen: dict[int, tuple[str, float]] = {}
        self.stop = threading.Event()
        self.me = psutil.Process()
        self.start_cpu = sum(self.me.cpu_times()[:2])

    def run(self) -> None:
        while not self.stop.wait(self.interval):
            for child in self.me.children(recursive=True):
                try:
                    line = " ".join(child.cmdline())
                    used = sum(child.cpu_times()[:2])
                except (psutil.NoSuchProcess, psutil.AccessDenied):
                    continue
                kind = "ray" if any(w in line for w in self.RAYS_OWN) else "workers"
                self.seen[child.pid] = (self.seen.get(child.pid, (kind, 0.0))[0], used)

    def totals(self) -> dict[str, float]:
        self.stop.set()
        self.join()
        out = {"driver": sum(self.me.cpu_times()[:2]) - self.start_cpu, "ray": 0.0, "workers": 0.0}
        for kind, used in self.seen.values():
            out[kind] += used
        return {k: round(v, 1) for k, v in out.items()}


def timed_suite(
    root: Path, demos: bytes, args: argparse.Namespace, workers: int
) -> tuple[float, dict[str, object]]:
    out = root / f"workers-{workers}"
    out.mkdir()
    (out / "demos.mcap").write_bytes(demos)
    ledger = CpuLedger()
    ledger.start()
    started = time.perf_counter()
    summary = run_suite(
        out,
        args.archs,
        args.seeds,
        episodes=args.episodes,
        curve_episodes=0,
        epochs=args.epochs,
        sweep=SweepOptions(workers=workers, ray=True, threads=1),
    )
    wall = time.perf_counter() - started
    summary["cpu_s"] = ledger.totals()
    return wall, summary


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--archs", nargs="+", default=["gcn", "sage"])
    parser.add_argument("--seeds", type=int, nargs="+", default=[0, 1])
    parser.add_argument("--epochs", type=int, default=40)
    parser.add_argument("--episodes", type=int, default=20, help="episodes per table cell")
    parser.add_argument("--workers", type=int, default=2)
    args = parser.parse_args()

    load_before = os.getloadavg()
    ray_tmp_before = du_kib(RAY_TMP)
    with tempfile.TemporaryDirectory(prefix="bench-ray-suite-") as tmp:
        root = Path(tmp)
        demo_path = root / "demos.mcap"
        record_demos(load_policy("expert"), DemoProtocol(trajectories=4), demo_path, None)
        demos = demo_path.read_bytes()
        fixed_one = fixed_cost(1)
        fixed_many = fixed_cost(args.workers)
        one_s, one = timed_suite(root, demos, args, 1)
        many_s, many = timed_suite(root, demos, args, args.workers)
    load_after = os.getloadavg()
    ray_tmp_after = du_kib(RAY_TMP)
    left = sorted(p.name for p in Path(temp_root()).glob(f"{TEMP_PREFIX}{os.getpid()}-*"))
    cells = len(args.archs) * len(args.seeds) * (1 + len(table_cells(args.episodes)))
    identical = one["results"] == many["results"]
    speedup = one_s / many_s
    work_one = one_s - fixed_one["total_s"]
    work_many = many_s - fixed_many["total_s"]
    work_speedup = work_one / work_many
    clean = ray_tmp_after <= ray_tmp_before and not left
    print(f"driver under uv run: {under_uv_run()}")
    print(f"cells: {cells} ({len(args.archs)} archs x {len(args.seeds)} seeds x (training + 8))")
    print(f"1 worker:  {one_s:7.1f} s")
    print(f"{args.workers} workers: {many_s:7.1f} s")
    print(f"speed-up:  {speedup:7.2f}x (target >= {SPEEDUP_TARGET}x)")
    for name, cost in (("1 worker", fixed_one), (f"{args.workers} workers", fixed_many)):
        print(
            f"Ray's fixed cost, {name}: {cost['total_s']:.1f} s (init {cost['init_s']:.1f}, "
            f"workers' first task {cost['first_task_s']:.1f}, shutdown {cost['shutdown_s']:.1f})"
        )
    print(f"cells' own work: {work_one:.1f} vs {work_many:.1f} s: {work_speedup:.2f}x")
    for name, run in (("1 worker", one), (f"{args.workers} workers", many)):
        cpu = run["cpu_s"]
        print(f"CPU s, {name}: {cpu} (workers: the cells; ray: GCS, raylet, agents)")
    print(f"success rates identical: {identical}")
    print(
        f"/tmp/ray: {ray_tmp_before} KiB before, {ray_tmp_after} KiB after; left: {left or 'none'}"
    )
    loads = f"before {load_before[0]:.2f}, after {load_after[0]:.2f}"
    print(f"load average {loads}, cpus {os.cpu_count()}")
    print(
        json.dumps(
            {
                "bench": "ray_suite",
                "under_uv_run": under_uv_run(),
                "cells": cells,
                "episodes_per_cell": args.episodes,
                "epochs": args.epochs,
                "workers": args.workers,
                "one_worker_s": round(one_s, 2),
                "many_workers_s": round(many_s, 2),
                "speedup": round(speedup, 3),
                "target": SPEEDUP_TARGET,
                "meets_target": speedup >= SPEEDUP_TARGET,
                "fixed_cost_one": fixed_one,
                "fixed_cost_many": fixed_many,
                "work_speedup": round(work_speedup, 3),
                "cpu_s_one": one["cpu_s"],
                "cpu_s_many": many["cpu_s"],
                "identical_success_rates": identical,
                "ray_tmp_kib_before": ray_tmp_before,
                "ray_tmp_kib_after": ray_tmp_after,
                "session_folders_left": left,
                "load_before": [round(x, 2) for x in load_before],
                "load_after": [round(x, 2) for x in load_after],
                "cpus": os.cpu_count(),
                "ray": importlib.metadata.version("ray"),
            }
        )
    )
    return 0 if identical and clean else 1


if __name__ == "__main__":
    sys.exit(main())
