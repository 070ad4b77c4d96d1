"""Decisions across a 20 ms RTT link beside the same on loopback: two sites, each its own router.

Site a holds cell-1's sim and skills, site b the planner; router b is linked to router a over
mutual TLS with per-cell access control (docs/scaling.md, *Several hosts*). The same layout
runs twice in one invocation:

* **loopback**: both sites on this machine's loopback, routers on two ports, no delay;
* **netns**: the sites in two Linux network namespaces joined by a veth pair with ``--rtt-ms``
  of round trip (``tc netem`` on each end; where the kernel lacks netem,
  ``manigraph_testkit.delay_link`` relays the router link with half the RTT each way).

Latency per decision: the scene's ``stamp`` (the sim, site a) to its Action's arrival back at
site a, both on this machine's clock; the scene crosses the link, the planner decides, the
Action crosses back. Target (issue 29): netns p50 <= RTT + 3 ms, success 1.0 over 20
episodes. Needs root (``ip netns``). Ends with one JSON line ``{"bench": "netem", ...}``.

    sudo .venv/bin/python bench/bench_netem.py [--episodes 20 --blocks 9 --policy ...]
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import sys
import tempfile
import time
from pathlib import Path

from manigraph_testkit.netlab import (
    Sites,
    TwoHosts,
    decision_latencies_ms,
    loopback_hosts,
    netns_problem,
)
from manigraph_testkit.testing import free_port
from manigraph_tools.access import cell_identities, write_cell_identities
from manigraph_tools.certificates import IDENTITIES, make_certificates

CELLS = {
    **cell_identities(["cell-1"]),
    "planner.site-b": ("cell-1",),
    "router.site-a": (),
    "router.site-b": (),
}


def percentile(values: list[float], q: float) -> float:
    ordered = sorted(values)
    return ordered[min(len(ordered) - 1, round(q * (len(ordered) - 1)))]


def measure(sites: Sites, args: argparse.Namespace, name: str) -> dict[str, object]:
    sites.start()
    sites.wait_ready()
    run_args = ["--blocks", str(args.blocks), "--episodes", str(args.episodes), "--json"]
    sites.run("cell-1", "--blocks", str(args.blocks), "--episodes", "1", "--seed", "999")  # warm
    with sites.listening(name) as events:
        result = sites.run("cell-1", *run_args, timeout=600)
    lines = [line for line in result.stdout.splitlines() if line.startswith("{")]
    if not lines:
        raise SystemExit(f"{name}: the run printed no JSON:\n{result.stderr[-3000:]}")
    summary = json.loads(lines[-1])
    latencies = decision_latencies_ms(events)
    figures = {
        "decisions": len(latencies),
        "p50_ms": round(statistics.median(latencies), 2),
        "p99_ms": round(percentile(latencies, 0.99), 2),
        "success_rate": summary["success_rate"],
        "episodes": summary["episodes"],
    }
    print(f"{name}: {figures}", file=sys.stderr, flush=True)
    return figures


def make_certs(directory: Path, hosts: list[str]) -> Path:
    make_certificates(directory, [*IDENTITIES, *CELLS], hosts=hosts, force=True)
    write_cell_identities(directory, CELLS)
    return directory


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--episodes", type=int, default=20)
    parser.add_argument("--blocks", type=int, default=9)
    parser.add_argument("--policy", default="checkpoints/sage.pt")
    parser.add_argument("--rtt-ms", type=float, default=20.0)
    args = parser.parse_args()
    problem = netns_problem()
    if problem:
        raise SystemExit(f"bench_netem: {problem}")
    load_before = os.getloadavg()
    tmp = Path(tempfile.mkdtemp(prefix="bench-netem-"))
    a, b = loopback_hosts()
    ports = (free_port(), free_port())
    loop_dir = tmp / "loopback"
    loop_dir.mkdir()
    certs = make_certs(tmp / "certs-loopback", [])
    loopback = Sites(a, b, link=f"127.0.0.1:{ports[0]}", ports=ports, certs=certs,
                     log_dir=loop_dir, policy=args.policy)  # fmt: skip
    try:
        on_loopback = measure(loopback, args, "loopback")
    finally:
        a.stop_all()
        b.stop_all()
    net_dir = tmp / "netns"
    net_dir.mkdir()
    with TwoHosts(args.rtt_ms) as hosts:
        certs = make_certs(tmp / "certs-netns", [hosts.a.address, hosts.b.address])
        link = hosts.link(7447, 7448, net_dir / "delay-link.log")
        sites = Sites(hosts.a, hosts.b, link=link, ports=(7447, 7447), certs=certs,
                      log_dir=net_dir, policy=args.policy)  # fmt: skip
        across = measure(sites, args, "netns")
        delay_by = hosts.delay_by
    load_after = os.getloadavg()
    p50 = float(str(across["p50_ms"]))
    result = {
        "bench": "netem",
        "rtt_ms": args.rtt_ms,
        "delay_by": delay_by,
        "blocks": args.blocks,
        "policy": args.policy,
        "episodes": args.episodes,
        "loopback": on_loopback,
        "netns": across,
        "p50_over_rtt_ms": round(p50 - args.rtt_ms, 2),
        "p50_added_by_link_ms": round(p50 - float(str(on_loopback["p50_ms"])), 2),
        "targets_met": p50 <= args.rtt_ms + 3.0 and across["success_rate"] == 1.0,
        "load": [round(load_before[0], 2), round(load_after[0], 2)],
        "date": time.strftime("%Y-%m-%d"),
    }
    print(f"logs in {tmp}", file=sys.stderr)
    print(json.dumps(result))


if __name__ == "__main__":
    main()
