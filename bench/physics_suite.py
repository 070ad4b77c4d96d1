"""The physics task suite (issue 15): every cell through router, physics sim, planner and skills
as separate processes, for each policy given.

Cells: K-block stacking K = 3..9, the 6-pyramid, the 3 x 3 multistack (3 stacks of 3 blocks),
box pack, box unpack and box rearrangement at K = 3 and 4. Each cell is ``--episodes`` episodes
from ``--seed``.

Two ways to run the processes:

* default: one ``manigraph up --sim physics --policy P`` stack per policy, and one
  ``manigraph run`` client per cell against it (the services are started once per policy;
  on a loaded 2-core machine a stack's start costs 1-2 minutes, so 30 stacks cost an hour);
* ``--stack-per-cell``: one ``manigraph up --sim physics ... --episodes N --json`` per cell.

Either way every episode crosses the bus between four processes. Writes the JSON after every
cell (``--out``) and prints a Markdown table at the end (also written beside the JSON)::

    nice -n 10 python bench/physics_suite.py --out results/physics/suite.json
    python bench/physics_suite.py --policies sage=checkpoints/sage.pt \
        --cells stack-3,box-rearrangement-4
"""

from __future__ import annotations

import argparse
import json
import os
import signal
import subprocess
import sys
import threading
import time
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path

CLI = [sys.executable, "-m", "manigraph_shared.cli"]


@dataclass(frozen=True)
class Cell:
    name: str
    label: str
    args: tuple[str, ...]


def suite_cells() -> list[Cell]:
    cells = [
        Cell(f"stack-{k}", f"stacking K={k}", ("--task", "stack", "--blocks", str(k)))
        for k in range(3, 10)
    ]
    cells.append(Cell("pyramid-6", "6-pyramid", ("--task", "pyramid", "--blocks", "6")))
    cells.append(
        Cell(
            "multistack-3x3",
            "3x3 multistack",
            ("--task", "multistack", "--blocks", "3", "--stacks", "3"),
        )
    )
    for task in ("box-pack", "box-unpack", "box-rearrangement"):
        for k in (3, 4):
            cells.append(Cell(f"{task}-{k}", f"{task} K={k}", ("--task", task, "--blocks", str(k))))
    return cells


def run_order(cells: list[Cell]) -> list[Cell]:
    """Box rearrangement first (issue 15's open cell), then the rest in table order."""
    return sorted(cells, key=lambda c: not c.name.startswith("box-rearrangement"))


def parse_policies(text: str) -> dict[str, str]:
    policies: dict[str, str] = {}
    for item in text.split(","):
        name, sep, path = item.partition("=")
        if not sep or not name or not path:
            raise SystemExit(f"--policies: expected name=path[,name=path], got {item!r}")
        policies[name] = path
    return policies


@contextmanager
def running_stack(policy: str, port: int, log_dir: Path) -> Iterator[str]:
    """``manigraph up --sim physics`` without episodes; yields its endpoint once every service
    is alive, stops it (SIGTERM) afterwards."""
    log_dir.mkdir(parents=True, exist_ok=True)
    argv = [*CLI, "up", "--sim", "physics", "--policy", policy, "--port", str(port)]
    argv += ["--log-dir", str(log_dir)]
    process = subprocess.Popen(argv, stderr=subprocess.PIPE, stdout=subprocess.DEVNULL, text=True)
    up = threading.Event()
    tail: list[str] = []

    def read() -> None:
        assert process.stderr is not None
        for line in process.stderr:
            tail[:] = [*tail[-20:], line.rstrip()]
            if line.startswith("stack is up"):
                up.set()

    threading.Thread(target=read, daemon=True).start()
    try:
        deadline = time.monotonic() + 1800.0  # minutes at load 30 on two cores
        while not up.wait(1.0):
            if process.poll() is not None or time.monotonic() > deadline:
                raise RuntimeError("the stack did not come up:\n" + "\n".join(tail))
        yield f"tcp/127.0.0.1:{port}"
    finally:
        if process.poll() is None:
            process.send_signal(signal.SIGTERM)
            try:
                process.wait(60)
            except subprocess.TimeoutExpired:
                process.kill()
                process.wait()


def last_json(stdout: str) -> dict[str, object] | None:
    for line in reversed(stdout.strip().splitlines()):
        if line.startswith("{"):
            return json.loads(line)
    return None


def run_cell(argv: list[str], attempts: int = 2) -> dict[str, object]:
    """Run one cell's command; a command that prints no summary (a stack that never came up on
    a loaded machine) is tried once more, then reported as an error."""
    error = ""
    for _ in range(attempts):
        done = subprocess.run(argv, capture_output=True, text=True)
        summary = last_json(done.stdout)
        if summary is not None:
            return summary
        error = (done.stderr.strip().splitlines() or ["no output"])[-1]
    return {"error": error}


def cell_row(summary: dict[str, object]) -> dict[str, object]:
    if "error" in summary:
        return {"error": summary["error"]}
    results = summary["results"]
    assert isinstance(results, list)
    failed = [
        {
            "seed": r["seed"],
            "reason": r["reason"],
            "goals": f"{r['goals_filled']}/{r['goals_total']}",
            "refusals": r.get("refusals", {}),
        }
        for r in results
        if not r["success"]
    ]
    return {
        "episodes": summary["episodes"],
        "success_rate": summary["success_rate"],
        "goals_filled_rate": summary["goals_filled_rate"],
        "mean_steps": summary["mean_steps"],
        "seconds_per_episode": summary["mean_seconds"],
        "refusals": summary.get("refusals", {}),
        "failed": failed,
    }


def record(
    report: dict[str, object],
    out: Path,
    policy: str,
    cell: Cell,
    summary: dict[str, object],
    started: float,
) -> None:
    """Add one cell's row to ``report`` and rewrite ``out`` (a killed run keeps what it did)."""
    row = cell_row(summary)
    row["wall_seconds"] = round(time.monotonic() - started, 1)
    row["load"] = os.getloadavg()[0]
    rows = report["cells"]
    assert isinstance(rows, dict)
    rows.setdefault(cell.name, {})[policy] = row
    out.write_text(json.dumps(report, indent=1))
    shown = row.get("error") or f"{row['success_rate']:.2f} failed {row['failed']}"
    print(f"{policy} {cell.label}: {shown}", file=sys.stderr, flush=True)


def refusals_text(refusals: dict[str, int]) -> str:
    """``3 (no_ik_solution 2, collision 1)``, or ``0``."""
    if not refusals:
        return "0"
    named = ", ".join(f"{reason} {count}" for reason, count in refusals.items())
    return f"{sum(refusals.values())} ({named})"


def markdown(report: dict[str, object]) -> str:
    policies = list(report["policies"])  # type: ignore[call-overload]
    rows = report["cells"]
    assert isinstance(rows, dict)
    head = "| cell | " + " | ".join(
        f"{p} success | {p} goals filled | {p} s/episode | {p} refusals" for p in policies
    )
    lines = [head + " |", "|---" * (1 + 4 * len(policies)) + "|"]
    for name, label in report["labels"].items():  # type: ignore[attr-defined]
        cells = []
        for policy in policies:
            row = rows.get(name, {}).get(policy)
            if row is None:
                cells += ["-", "-", "-", "-"]
            elif "error" in row:
                cells += ["error", "-", "-", "-"]
            else:
                ok = round(row["success_rate"] * row["episodes"])
                cells += [
                    f"{ok}/{row['episodes']} ({row['success_rate']:.2f})",
                    f"{row['goals_filled_rate']:.3f}",
                    f"{row['seconds_per_episode']:.2f}",
                    refusals_text(row.get("refusals", {})),
                ]
        lines.append(f"| {label} | " + " | ".join(cells) + " |")
    return "\n".join(lines) + "\n"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument(
        "--policies",
        default="sage=checkpoints/sage.pt,gat=checkpoints/gat.pt",
        help="name=path,...",
    )
    parser.add_argument("--cells", help="comma-separated cell names (default: all)")
    parser.add_argument("--episodes", type=int, default=20)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--port", type=int, default=17710, help="first router port; +1 per stack")
    parser.add_argument("--stack-per-cell", action="store_true")
    parser.add_argument("--out", type=Path, default=Path("results/physics/suite.json"))
    args = parser.parse_args()
    policies = parse_policies(args.policies)
    cells = suite_cells()
    if args.cells:
        wanted = args.cells.split(",")
        unknown = sorted(set(wanted) - {c.name for c in cells})
        if unknown:
            raise SystemExit(f"--cells: unknown {unknown}; known: {[c.name for c in cells]}")
        cells = [c for c in cells if c.name in wanted]
    args.out.parent.mkdir(parents=True, exist_ok=True)
    report: dict[str, object] = {
        "command": " ".join(sys.argv),
        "episodes": args.episodes,
        "seed": args.seed,
        "mode": "stack per cell" if args.stack_per_cell else "one stack per policy",
        "load_at_start": os.getloadavg(),
        "policies": policies,
        "labels": {c.name: c.label for c in cells},
        "cells": {},
    }
    episodes = ["--episodes", str(args.episodes), "--seed", str(args.seed), "--json"]
    # Generous per-episode limits: on a starved machine a slow episode is not a failed one.
    episodes += ["--timeout", "600", "--stall-timeout", "180"]
    for index, (name, path) in enumerate(policies.items()):
        port = args.port + index
        log_dir = args.out.parent / f"logs-{name}"

        if args.stack_per_cell:
            for cell in run_order(cells):
                started = time.monotonic()
                argv = [*CLI, "up", "--sim", "physics", "--policy", path, "--port", str(port)]
                record(
                    report, args.out, name, cell, run_cell([*argv, *cell.args, *episodes]), started
                )
            continue
        with running_stack(path, port, log_dir) as endpoint:
            bus = ["-m", "client", "-e", endpoint, "--wait-seconds", "600"]
            for cell in run_order(cells):
                started = time.monotonic()
                record(
                    report,
                    args.out,
                    name,
                    cell,
                    run_cell([*CLI, "run", *bus, *cell.args, *episodes]),
                    started,
                )
    report["load_at_end"] = os.getloadavg()
    args.out.write_text(json.dumps(report, indent=1))
    table = markdown(report)
    args.out.with_suffix(".md").write_text(table)
    print(table)


if __name__ == "__main__":
    main()
