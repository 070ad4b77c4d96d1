"""`manigraph replay`: a recorded log back onto the bus; `--expect-actions` checks a live
planner's decisions against it, stopping at the first that differs (`--keep-going`: all)."""

from __future__ import annotations

import argparse
import sys
import threading
import time
from pathlib import Path

from manigraph_shared.bus import Bus
from manigraph_shared.bus_config import add_bus_arguments, bus_config_from_args
from manigraph_shared.cli import Command
from manigraph_shared.errors import INTERRUPTED_EXIT_CODE, ConfigError
from manigraph_shared.mcap_log import LoggedMessage
from manigraph_shared.messages import Action
from manigraph_tools.commands.common import emit_json, wait_services
from manigraph_tools.log_replay import ActionCheck, Replayer, recorded_actions


def _replay_configure(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("file", type=Path, help="MCAP log written by manigraph record")
    parser.add_argument("--speed", type=float, default=1.0, help="time scale (2 = twice as fast)")
    parser.add_argument("--loop", action="store_true", help="start over at the end until Ctrl-C")
    parser.add_argument("--topics", nargs="+", default=[], help="key patterns to publish")
    parser.add_argument("--exclude", nargs="+", default=[], help="key patterns to skip")
    parser.add_argument(
        "--expect-actions",
        action="store_true",
        help="withhold the recorded planner decisions and require a live planner to repeat them",
    )
    parser.add_argument(
        "--wait-for", nargs="*", default=None, help="services that must be alive before playing"
    )
    parser.add_argument(
        "--decision-timeout",
        type=float,
        default=5.0,
        help="with --expect-actions: seconds to wait for each live decision (default 5)",
    )
    parser.add_argument(
        "--keep-going",
        action="store_true",
        help="with --expect-actions: check every decision rather than stop at the first that "
        "differs",
    )
    add_bus_arguments(parser)


def _replay_run(args: argparse.Namespace) -> int:
    if args.decision_timeout <= 0:
        raise ConfigError("decision-timeout", f"must be > 0 seconds, got {args.decision_timeout:g}")
    withhold = [Action.key] if args.expect_actions else []
    wait_for = (
        args.wait_for if args.wait_for is not None else (["planner"] if args.expect_actions else [])
    )
    with Bus.open(bus_config_from_args(args, wait_seconds=30.0)) as bus:
        check = ActionCheck(expected=recorded_actions(args.file) if args.expect_actions else {})
        if args.expect_actions:
            bus.subscribe(Action, check.receive)
        wait_services(bus, wait_for)
        replayer = Replayer(
            bus,
            args.file,
            args.speed,
            args.topics,
            args.exclude,
            withhold,
            skip_start_up=args.expect_actions,
        )
        stop = threading.Event()
        diverged = threading.Event()

        def await_live_decision(item: LoggedMessage) -> None:
            line = check.check(Action.decode(item.data, item.topic), args.decision_timeout)
            if line is None:
                return
            print(f"MISMATCH {line}", file=sys.stderr, flush=True)
            diverged.set()
            if not args.keep_going:  # later scenes follow the recorded choice, not the live one
                stop.set()

        print(f"replaying {len(replayer.messages)} messages from {args.file}", file=sys.stderr)
        interrupted = False  # Ctrl-C: the summary so far, then the interrupted status
        try:
            while not stop.is_set():
                replayer.play(stop, on_withheld=await_live_decision)
                if not args.loop:
                    break
        except KeyboardInterrupt:
            stop.set()
            interrupted = True
        if not args.expect_actions:
            return INTERRUPTED_EXIT_CODE if interrupted else 0
        stopped_early = diverged.is_set() and not args.keep_going
        problems = list(check.problems)
        if not stop.is_set():
            time.sleep(0.5)  # a decision the log does not have would arrive now
            for line in check.unexpected():
                print(f"MISMATCH {line}", file=sys.stderr)
                problems.append(line)
        if stopped_early:
            print(
                f"stopped at the first divergence, after {len(check.reached)} of the log's "
                f"{len(check.expected)} decisions (--keep-going checks them all)",
                file=sys.stderr,
            )
        emit_json(
            {
                "file": str(args.file),
                "decisions_expected": len(check.expected),
                "decisions_checked": len(check.reached),
                "decisions_received": len(check.received),
                "mismatches": len(problems),
                "first_mismatch": problems[0] if problems else None,
                "stopped_early": stopped_early,
                "identical": not problems,
            }
        )
        if interrupted:
            return INTERRUPTED_EXIT_CODE
        return 0 if not problems else 1


command = Command(
    help="publish a recorded MCAP log back onto the bus with its original timing",
    configure=_replay_configure,
    run=_replay_run,
)
