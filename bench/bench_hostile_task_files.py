"""What a hostile task file costs the sim: the refusal of a matching bomb, beside a normal file.

``manigraph_testkit.hostile_task_files.matching_bomb``: objects listing 64 copies of one value
of a shuffled attribute, goals accepting a value none has. The check that pooled every
object's values took 8.8 s for 13 KB and minutes for 60 KB, on the sim's only thread (issue
48). Target: the 60 KB file refused in <= 0.5 s.

Measured through the real path a reset takes: a router and a geometric sim on a loopback port
of their own, a client's reset query carrying the file, from ``get`` to the end of the query
(each file made unique per run, so no kept outcome is reused). Beside it, in the same run, the
reset of a normal four-object file (``reference_file``), which starts an episode. Then, with
``--in-process``, the check alone (``parse_task_file``) for each file.

    .venv/bin/python bench/bench_hostile_task_files.py [--runs 5] [--in-process]

One line per file and a JSON summary with the load average. Not a test.
"""

from __future__ import annotations

import argparse
import contextlib
import json
import os
import statistics
import tempfile
import time
from pathlib import Path

from manigraph_shared.bus import Bus
from manigraph_shared.errors import TaskError
from manigraph_shared.messages import EpisodeRequest
from manigraph_testkit.hostile_task_files import matching_bomb, reference_file
from manigraph_testkit.testing import stack

FILES = {
    "bomb 13 KB": lambda: matching_bomb(13_000),
    "bomb 60 KB": lambda: matching_bomb(60_000),
    "reference": reference_file,
}


def reset_seconds(bus: Bus, text: str, run: int) -> tuple[float, str]:
    """One reset query with ``text`` (made unique by a comment): seconds and its outcome."""
    request = EpisodeRequest(
        episode_id=f"hostile-{run}", task="file", task_file=f"{text}\n# run {run}\n"
    )
    started = time.perf_counter()
    replies = list(
        bus.session.get(bus.scoped(EpisodeRequest.key), payload=request.encode(), timeout=60)
    )
    seconds = time.perf_counter() - started
    if not replies:
        return seconds, "no reply"
    if replies[0].err is not None:
        return seconds, "refused: " + replies[0].err.payload.to_string()[:90]
    return seconds, "episode started"


def in_process_seconds(text: str, run: int) -> float:
    from manigraph_blocks.sim.task_file import parse_task_file

    started = time.perf_counter()
    with contextlib.suppress(TaskError):
        parse_task_file(f"{text}\n# in-process {run}\n")
    return time.perf_counter() - started


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=5)
    parser.add_argument("--in-process", action="store_true", help="also time the check alone")
    args = parser.parse_args()
    texts = {name: make() for name, make in FILES.items()}
    summary: dict[str, object] = {}
    with tempfile.TemporaryDirectory() as logs, stack(Path(logs)) as running:
        running.start("router")
        running.start("sim", "sim", "--backend", "geometric")
        with running.client() as bus:
            running.wait_alive(bus, "sim")
            for name, text in texts.items():
                timed = [reset_seconds(bus, text, run) for run in range(args.runs)]
                median = statistics.median(s for s, _ in timed)
                print(f"{name:12} {len(text):6,} chars  reset median {median * 1e3:8.1f} ms  "
                      f"({timed[-1][1]})")  # fmt: skip
                summary[f"{name} reset_ms"] = round(median * 1e3, 1)
    if args.in_process:
        for name, text in texts.items():
            median = statistics.median(in_process_seconds(text, run) for run in range(args.runs))
            print(f"{name:12} check alone median {median * 1e3:8.1f} ms")
            summary[f"{name} check_ms"] = round(median * 1e3, 1)
    summary["target_60kb_ms"] = 500
    summary["load_average"] = [round(v, 2) for v in os.getloadavg()]
    print(json.dumps(summary))


if __name__ == "__main__":
    main()
