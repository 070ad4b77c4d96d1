"""Memory under scene floods: every service's RSS before, during and a minute after 30 s of
valid scenes and then 30 s of invalid (NaN) scenes at 10,000 per second.

Target (issue 16): RSS back within 20 % of its starting value a minute after each flood.
The stack is warmed with one episode first, so lazy start-up allocations are in the baseline.

    python bench/soak_flood.py                       # 30 s floods at 10 k/s, 60 s settle
    python bench/soak_flood.py --seconds 5 --settle 10   # quick look
"""

from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path

from soak_stack import SERVICES, soak_stack  # bench/soak_stack.py

from manigraph_testkit.flood import flood_scenes


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--seconds", type=float, default=30.0, help="flood length")
    parser.add_argument("--rate", type=float, default=10_000.0, help="scenes per second")
    parser.add_argument("--settle", type=float, default=60.0, help="wait before the reading")
    parser.add_argument("--policy", default="expert")
    args = parser.parse_args()
    rows = []
    with tempfile.TemporaryDirectory() as tmp, soak_stack(Path(tmp), args.policy) as soak:
        warm = soak.running.run("run", "--blocks", "4", "--episodes", "1", "--json", timeout=1800)
        assert warm.returncode == 0, warm.stderr[-2000:]
        for valid in (True, False):
            before = soak.rss()
            started = time.perf_counter()
            sent = flood_scenes(soak.bus, args.seconds, args.rate, valid)
            rate = sent / (time.perf_counter() - started)
            peak = soak.rss()
            time.sleep(args.settle)
            after = soak.rss()
            for name in SERVICES:
                rows.append((valid, name, sent, rate, before[name], peak[name], after[name]))
        dead = soak.dead()
        final = soak.running.run("run", "--blocks", "4", "--episodes", "1", "--json", timeout=1800)
    print(f"scene floods: {args.seconds:g} s at {args.rate:g}/s, RSS read {args.settle:g} s after")
    print(
        "| flood | service | sent | rate/s | RSS before MiB | at end MiB | after MiB "
        "| change | held |"
    )
    print("|---|---|---|---|---|---|---|---|---|")
    broke = 0
    for valid, name, sent, rate, before, peak, after in rows:
        change = (after - before) / before if before else float("nan")
        held = "held" if abs(change) <= 0.20 else "BROKE"
        broke += held != "held"
        print(
            f"| {'valid' if valid else 'invalid (NaN)'} | {name} | {sent} | {rate:.0f} | "
            f"{before:.0f} | {peak:.0f} | {after:.0f} | {change:+.0%} | {held} |"
        )
    episode_ok = final.returncode == 0 and '"success_rate": 1.0' in final.stdout
    print(
        f"dead processes: {dead or 'none'}; episode after the floods: "
        f"{'success' if episode_ok else 'FAILED'}"
    )
    raise SystemExit(0 if not broke and not dead and episode_ok else 1)


if __name__ == "__main__":
    main()
