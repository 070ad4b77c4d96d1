"""How soon a fresh stack explains: planner ready -> explainer ready, and ``explain`` right
after the first episode.

Each run starts a fresh stack on its own loopback port (router, geometric sim, the planner
serving a checkpoint, skills) and measures:

1. ``ready_gap_s``: from the planner's liveliness token (it is ``ready``) to the first explain
   query (on a 3-block scene) that is answered rather than refused ``explainer_warming_up``;
   queries go every 20 ms from before the planner is alive. Target: <= 2 s (issue 45 item 5).
2. ``first_explain_s``: once ``manigraph run`` of one 3-block episode returns, one
   ``ExplainRequest`` for the latest decision, to its answer. Target: <= 1 s on a quiet
   machine.
3. ``cli_explain_s``: the same through ``manigraph explain --json`` (process start included).

    .venv/bin/python bench/bench_explainer_ready.py [--runs 3] [--checkpoint checkpoints/sage.pt]

Prints one line per run and a JSON summary (with the load average) on the last line.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import tempfile
import threading
import time
from pathlib import Path

from scenes import stack_scene

from manigraph_shared.errors import BusError, RequestRefused
from manigraph_shared.messages import EXPLAINER_WARMING_UP, ExplainRequest, Explanation
from manigraph_testkit.testing import stack

ROOT = Path(__file__).resolve().parents[1]
READY_TARGET_S = 2.0
EXPLAIN_TARGET_S = 1.0


def one_run(checkpoint: Path) -> dict[str, float]:
    with tempfile.TemporaryDirectory() as logs, stack(Path(logs)) as running:
        running.start("router")
        with running.client() as bus:
            running.wait_alive(bus, "router")
            planner_alive = threading.Event()
            alive_at: list[float] = []

            def on_alive(service: str, alive: bool) -> None:
                if service == "planner" and alive and not planner_alive.is_set():
                    alive_at.append(time.monotonic())
                    planner_alive.set()

            bus.watch_alive(on_alive)
            running.start("sim", "sim", "--backend", "geometric")
            running.start("skills", "skills")
            running.start("planner", "planner", "--policy", str(checkpoint))
            request = ExplainRequest(scene=stack_scene(3))
            answered_at = None
            deadline = time.monotonic() + 180
            while answered_at is None and time.monotonic() < deadline:
                try:
                    bus.request(request, Explanation, timeout=2.0)
                    answered_at = time.monotonic()
                except RequestRefused as exc:
                    if EXPLAINER_WARMING_UP not in str(exc):
                        raise
                except BusError:  # no planner yet: nobody answers
                    pass
                time.sleep(0.02)
            if answered_at is None or not planner_alive.wait(60):
                raise SystemExit(
                    "the planner or its explainer never came up:\n" + running.log("planner")
                )
            running.wait_alive(bus, "sim", "skills", "planner")
            episode = running.run("run", "--task", "stack", "--blocks", "3", "--episodes", "1")
            if episode.returncode != 0:
                raise SystemExit(f"run failed:\n{episode.stderr[-2000:]}")
            started = time.monotonic()
            bus.request(ExplainRequest(), Explanation, timeout=10.0)
            first_explain = time.monotonic() - started
        started = time.monotonic()
        cli = running.run("explain", "--json", "--timeout", "10")
        cli_explain = time.monotonic() - started
        if cli.returncode != 0:
            raise SystemExit(f"explain failed:\n{cli.stderr[-2000:]}")
        return {
            "ready_gap_s": max(0.0, answered_at - alive_at[0]),
            "first_explain_s": first_explain,
            "cli_explain_s": cli_explain,
        }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=3)
    parser.add_argument("--checkpoint", type=Path, default=ROOT / "checkpoints" / "sage.pt")
    args = parser.parse_args()
    runs = []
    for index in range(args.runs):
        result = one_run(args.checkpoint)
        runs.append(result)
        print(
            f"run {index}: planner ready -> explainer ready {result['ready_gap_s']:.2f} s, "
            f"first explain {result['first_explain_s'] * 1e3:.0f} ms, "
            f"CLI explain {result['cli_explain_s']:.2f} s",
            flush=True,
        )
    summary = {
        key: round(statistics.median(run[key] for run in runs), 3)
        for key in ("ready_gap_s", "first_explain_s", "cli_explain_s")
    }
    summary["ready_target_s"] = READY_TARGET_S
    summary["explain_target_s"] = EXPLAIN_TARGET_S
    summary["load_average"] = [round(v, 2) for v in os.getloadavg()]
    summary["runs"] = len(runs)
    print(json.dumps(summary))


if __name__ == "__main__":
    main()
