"""What a hostile checkpoint costs the planner before it is refused (issue 48 item 6).

Each checkpoint below is built in a temporary folder; each load runs in a fresh Python
process (``load_checkpoint(path, message_passing=False)``, what the planner serves with),
which prints the load's wall time and its peak RSS (``VmHWM``) before and after the load;
the parent adds the whole process's wall time (start and ``import torch`` included).
Beside them, the reference: the shipped ``checkpoints/sage.pt`` loaded the same way in the
same run. Target: each hostile one refused with one line, <= 200 MB above what importing
torch costs, <= 1 s.

* ``declared-4096x64``: sage.pt (80 KB) declaring hidden channels 4096 and 64 layers;
* ``declared-1024x16``: the same within the declared limits, beyond the stored weights;
* ``ensemble-4096``: a dishwasher checkpoint declaring 4096 members;
* ``zip-bomb``: sage.pt plus one 1 GiB tensor of zeros, every record deflated (~1.1 MB);
* ``reordered-vocabulary``: a task policy whose colour vocabulary and columns were
  reordered together;
* ``nan-weight``: sage.pt with one NaN weight.

Each child runs under an address-space cap on its data (``RLIMIT_DATA``, ``--cap-mb``,
default 4096): code that would allocate gigabytes fails there instead of taking a shared
machine's memory (as ``up`` saw it: an allocation error, exit 1, five restarts).

    .venv/bin/python bench/bench_hostile_checkpoints.py [--runs 3] [--cap-mb 4096]

One line per checkpoint (median of the runs) and a JSON summary with the load average.
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import statistics
import subprocess
import sys
import tempfile
import time
import zipfile
from collections.abc import Callable
from pathlib import Path
from typing import Any

import torch

REPO = Path(__file__).resolve().parents[1]
SAGE = REPO / "checkpoints" / "sage.pt"
DISHWASHER = REPO / "checkpoints" / "dishwasher-left-right-sage.pt"

CHILD = r"""
import json, sys, time
from manigraph_planner.gnn.checkpoint import load_checkpoint

def hwm():
    for line in open("/proc/self/status"):
        if line.startswith("VmHWM:"):
            return int(line.split()[1]) / 1024
before = hwm()
started = time.perf_counter()
try:
    load_checkpoint(sys.argv[1], message_passing=False)
    outcome, message = "loaded", ""
except Exception as exc:
    outcome, message = type(exc).__name__, str(exc)
seconds = time.perf_counter() - started
print(json.dumps({"outcome": outcome, "message": message, "seconds": seconds,
                  "hwm_before_mb": before, "hwm_after_mb": hwm()}))
"""


def rewritten(source: Path, target: Path, change: Callable[[dict[str, Any]], None]) -> Path:
    payload = torch.load(source, weights_only=True)
    change(payload)
    torch.save(payload, target)
    return target


def zip_bomb(target: Path, gib: float = 1.0) -> Path:
    """sage.pt plus a ``gib`` GiB tensor of zeros, every record deflated. ``torch.empty``
    of that size is fresh zero pages that ``torch.save`` only reads, so building it costs
    little memory; the stored archive goes through a temporary file."""
    payload = torch.load(SAGE, weights_only=True)
    payload["state_dict"]["bomb"] = torch.empty(int(gib * 2**28))
    with tempfile.TemporaryFile() as stored:
        torch.save(payload, stored)
        del payload
        stored.seek(0)
        with zipfile.ZipFile(stored) as source, zipfile.ZipFile(target, "w") as archive:
            for info in source.infolist():
                record = zipfile.ZipInfo(info.filename, info.date_time)
                record.compress_type = zipfile.ZIP_DEFLATED
                with source.open(info) as reader, archive.open(record, "w", force_zip64=True) as w:
                    while chunk := reader.read(2**22):
                        w.write(chunk)
    return target


def task_checkpoint(target: Path) -> Path:
    from manigraph_planner.gnn.checkpoint import save_checkpoint
    from manigraph_planner.gnn.features import FeatureSpec
    from manigraph_planner.gnn.models import ModelConfig, PolicyNet
    from manigraph_planner.gnn.task_features import AttributeColumns, TaskFeatures

    colours = AttributeColumns("colour", ("blue", "green", "red"))
    spec = FeatureSpec.for_task(TaskFeatures((colours,)))
    net = PolicyNet(ModelConfig("sage", features=spec))
    return save_checkpoint(target, net, training_config={}, data_hash="bench")


def reordered_vocabulary(target: Path) -> Path:
    def reorder(payload: dict[str, Any]) -> None:
        payload["feature_spec"]["task"]["attributes"][0]["vocabulary"] = ["red", "green", "blue"]
        names = payload["feature_spec"]["names"]
        first = names.index("colour=blue")
        names[first : first + 3] = ["colour=red", "colour=green", "colour=blue"]

    return rewritten(task_checkpoint(target), target, reorder)


def nan_weight(target: Path) -> Path:
    def poison(payload: dict[str, Any]) -> None:
        payload["state_dict"]["backbone.convs.1.lin_l.weight"][3, 7] = float("nan")

    return rewritten(SAGE, target, poison)


def declared(source: Path, **sizes: int) -> Callable[[Path], Path]:
    return lambda target: rewritten(source, target, lambda p: p["model"].update(sizes))


HOSTILE: dict[str, Callable[[Path], Path]] = {
    "declared-4096x64": declared(SAGE, hidden_channels=4096, num_layers=64),
    "declared-1024x16": declared(SAGE, hidden_channels=1024, num_layers=16),
    "ensemble-4096": declared(DISHWASHER, ensemble=4096),
    "zip-bomb": zip_bomb,
    "reordered-vocabulary": reordered_vocabulary,
    "nan-weight": nan_weight,
}


def load_in_child(path: Path, cap_mb: int) -> dict[str, Any]:
    def cap() -> None:
        limit = cap_mb * 2**20
        resource.setrlimit(resource.RLIMIT_DATA, (limit, limit))

    started = time.perf_counter()
    done = subprocess.run(
        [sys.executable, "-c", CHILD, str(path)],
        capture_output=True,
        text=True,
        preexec_fn=cap,
        check=False,
    )
    lines = done.stdout.strip().splitlines()
    if done.returncode != 0 or not lines:
        tail = done.stderr.strip().splitlines()[-1:] or ["no output"]
        return {"outcome": f"exit {done.returncode}", "message": tail[0], "seconds": None}
    result: dict[str, Any] = json.loads(lines[-1])
    result["process_seconds"] = time.perf_counter() - started
    result["added_mb"] = result["hwm_after_mb"] - result["hwm_before_mb"]
    return result


def measure(name: str, path: Path, runs: int, cap_mb: int) -> dict[str, Any]:
    results = [load_in_child(path, cap_mb) for _ in range(runs)]
    first = results[0]
    row: dict[str, Any] = {
        "file_kb": round(path.stat().st_size / 1024, 1),
        "outcome": first["outcome"],
        "message": first["message"][:160],
    }
    if first["seconds"] is not None and all(r["seconds"] is not None for r in results):
        row["seconds"] = round(statistics.median(r["seconds"] for r in results), 4)
        row["process_seconds"] = round(statistics.median(r["process_seconds"] for r in results), 2)
        row["peak_rss_mb"] = round(statistics.median(r["hwm_after_mb"] for r in results), 1)
        row["added_mb"] = round(statistics.median(r["added_mb"] for r in results), 1)
        print(
            f"{name:22s} {row['file_kb']:8.1f} KB  {row['outcome']:12s} "
            f"{row['seconds'] * 1e3:8.1f} ms ({row['process_seconds']:.1f} s with the process) "
            f"peak {row['peak_rss_mb']:7.1f} MB "
            f"(+{row['added_mb']:.1f} MB)  {row['message'][:100]}",
            flush=True,
        )
    else:
        print(f"{name:22s} {row['file_kb']:8.1f} KB  {row['outcome']}: {row['message']}")
    return row


def main() -> None:
    parser = argparse.ArgumentParser(description=(__doc__ or "").splitlines()[0])
    parser.add_argument("--runs", type=int, default=3)
    parser.add_argument("--cap-mb", type=int, default=4096, help="RLIMIT_DATA of each child")
    parser.add_argument("--only", nargs="*", choices=sorted(HOSTILE), help="these checkpoints")
    args = parser.parse_args()
    summary: dict[str, Any] = {"reference": {}, "hostile": {}}
    with tempfile.TemporaryDirectory() as folder:
        summary["reference"]["sage.pt"] = measure("reference sage.pt", SAGE, args.runs, args.cap_mb)
        for name, build in HOSTILE.items():
            if args.only and name not in args.only:
                continue
            path = build(Path(folder) / f"{name}.pt")
            summary["hostile"][name] = measure(name, path, args.runs, args.cap_mb)
    summary["targets"] = {"seconds": 1.0, "added_mb": 200}
    summary["load_average"] = [round(v, 2) for v in os.getloadavg()]
    print(json.dumps(summary))


if __name__ == "__main__":
    main()
