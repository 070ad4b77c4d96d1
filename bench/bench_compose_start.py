"""From ``docker compose up -d`` to the first finished episode, with where the time goes.

    python bench/bench_compose_start.py                 # project "bench-start", port 17620
    python bench/bench_compose_start.py -p rt --port 17621 --blocks 4

With built images (``docker/build.sh``), in the repository (its ``compose.yaml`` and ``.env``):
``docker compose up -d``, then at once ``docker compose run --rm tools manigraph run --blocks 4
--episodes 1 --json``, timed until the episode's JSON line. Prints one line per step (seconds
since ``up -d`` began: ``up -d`` returning, every container started, every service ready per
its log, the client's wait for services, the episode itself) and one JSON object last.
Always ends with ``docker compose down -v`` (the project's containers and its certs volume).
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import time
from datetime import datetime
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
SERVICES = ("certs", "router", "recorder", "sim", "planner", "skills")
#: The log line that says a service is serving (``Service.run``; the router's own).
READY = {"router": "zenoh router listening"}


def compose_command() -> list[str]:
    """`docker compose` (v2) where installed, else `docker-compose` (v1, Debian 12's)."""
    v2 = subprocess.run(["docker", "compose", "version"], capture_output=True, text=True)
    if v2.returncode == 0 and "compose" in v2.stdout.lower():
        return ["docker", "compose"]
    return ["docker-compose"]


COMPOSE = compose_command()


def compose(project: str, env: dict[str, str], *args: str, timeout: float = 600):  # type: ignore[no-untyped-def]
    return subprocess.run(
        [*COMPOSE, "-p", project, *args],
        cwd=REPO,
        env=env,
        capture_output=True,
        text=True,
        timeout=timeout,
        check=False,
    )


def parse_time(text: str) -> float:
    """Docker's RFC 3339 time (nanoseconds, ``Z``) as a Unix time."""
    text = text.strip().replace("Z", "+00:00")
    head, _, rest = text.partition(".")
    fraction, zone = (rest[:6], rest[rest.index("+") :]) if "+" in rest else ("0", "+00:00")
    return datetime.fromisoformat(f"{head}.{fraction.ljust(6, '0')}{zone}").timestamp()


def container_times(project: str, env: dict[str, str], service: str) -> tuple[float, float]:
    """When ``service``'s container started and (a one-shot) finished; nan if unknown."""
    ids = compose(project, env, "ps", "-a", "-q", service).stdout.split()
    if not ids:
        return float("nan"), float("nan")
    state = subprocess.run(
        ["docker", "inspect", "--format", "{{.State.StartedAt}} {{.State.FinishedAt}}", ids[0]],
        capture_output=True,
        text=True,
        check=False,
    ).stdout.split()
    started = parse_time(state[0]) if state else float("nan")
    finished = parse_time(state[1]) if len(state) > 1 and not state[1].startswith("0001") else 0.0
    return started, finished or float("nan")


def ready_time(project: str, env: dict[str, str], service: str) -> float:
    """When ``service`` logged that it is ready (its first such line); nan if it did not."""
    logs = compose(project, env, "logs", "--timestamps", "--no-color", service).stdout
    marker = READY.get(service, f"manigraph.{service}: ready")
    for line in logs.splitlines():
        if marker in line:
            stamp = line.split("|", 1)[-1].strip().split(" ", 1)[0]
            return parse_time(stamp)
    return float("nan")


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("-p", "--project", default="bench-start", help="compose project name")
    parser.add_argument("--port", type=int, default=17620, help="router port on 127.0.0.1")
    parser.add_argument("--blocks", type=int, default=4)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--give-up", type=float, default=420.0, help="seconds after up -d")
    args = parser.parse_args()
    logs = REPO / "logs"
    logs.mkdir(exist_ok=True)
    logs.chmod(0o777)  # the recorder runs as uid 1000
    env = {**os.environ, "MANIGRAPH_ROUTER_PORT": str(args.port)}
    env.setdefault("COMPOSE_PROFILES", "sim")
    report: dict[str, object] = {"load_before": round(os.getloadavg()[0], 2)}
    try:
        t0 = time.time()
        up = compose(args.project, env, "up", "-d")
        t_up = time.time() - t0
        if up.returncode != 0:
            raise SystemExit(f"docker compose up -d failed:\n{up.stderr[-3000:]}")
        print(f"{t_up:6.1f} s  docker compose up -d returned", file=sys.stderr)
        # A client image that gives up waiting for services (an older `manigraph run`
        # waited 60 s) is run again, as a user would; the attempts are reported.
        attempts = 0
        while True:
            attempts += 1
            run_started = time.time() - t0
            run = compose(
                args.project,
                env,
                "run",
                "--rm",
                "-T",
                "tools",
                "manigraph",
                "run",
                "--blocks",
                str(args.blocks),
                "--episodes",
                "1",
                "--seed",
                str(args.seed),
                "--json",
            )
            total = time.time() - t0
            if run.returncode == 0 and run.stdout.strip():
                break
            why = run.stderr.strip()[-200:]
            print(f"{total:6.1f} s  run attempt {attempts} failed: {why}", file=sys.stderr)
            if total > args.give_up:
                raise SystemExit(f"manigraph run failed:\n{run.stderr[-3000:]}")
        summary = json.loads(run.stdout.strip().splitlines()[-1])
        episode = summary["results"][0]
        report["run_attempts"] = attempts
        steps: dict[str, float] = {}
        for service in SERVICES:
            started, finished = container_times(args.project, env, service)
            steps[f"{service} container started"] = started - t0
            if service == "certs":
                steps["certs done"] = finished - t0
            else:
                steps[f"{service} ready"] = ready_time(args.project, env, service) - t0
        for name, at in sorted(steps.items(), key=lambda item: item[1]):
            print(f"{at:6.1f} s  {name}", file=sys.stderr)
        waited = total - run_started - float(episode["seconds"])
        print(
            f"{total:6.1f} s  episode JSON (client: {waited:.1f} s to start and find every "
            f"service, {episode['seconds']:.1f} s episode, success={episode['success']})",
            file=sys.stderr,
        )
        report.update(
            seconds_to_first_episode=round(total, 1),
            up_d_seconds=round(t_up, 1),
            client_wait_seconds=round(waited, 1),
            episode_seconds=episode["seconds"],
            success=episode["success"],
            steps={name: round(at, 1) for name, at in steps.items()},
        )
    finally:
        compose(args.project, env, "down", "-v", "--remove-orphans", "--timeout", "20")
    report["load_after"] = round(os.getloadavg()[0], 2)
    print(json.dumps(report))
    return 0


if __name__ == "__main__":
    sys.exit(main())
