"""``manigraph explain``: ask the running planner why it decided (or explain a logged decision
offline: :mod:`manigraph_lab.decision_explanations`), print it, draw it; ``--summary``: what a
policy learned (:mod:`manigraph_lab.explain_summary`)."""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

from manigraph_lab.decision_explanations import explain_offline, explain_online, summary
from manigraph_shared.bus_config import add_bus_arguments, bus_config_from_args
from manigraph_shared.cli import Command
from manigraph_shared.errors import ConfigError


def _configure(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--decision", help="decision id to explain (default: the latest)")
    parser.add_argument(
        "--seed",
        type=int,
        default=0,
        help="seed of the mask optimisation; with --summary, of the first episode (default 0)",
    )
    parser.add_argument("--json", action="store_true", help="last line: one JSON object")
    parser.add_argument("--png", type=Path, help="also draw the explanation to this PNG file")
    parser.add_argument("--timeout", type=float, default=4.0, help="seconds to wait (default 4)")
    offline = parser.add_argument_group("offline (no running stack)")
    offline.add_argument("--checkpoint", type=Path, help="GNN checkpoint to explain")
    offline.add_argument(
        "--scene-from", type=Path, help="MCAP log: explain its decision --decision (or the last)"
    )
    learned = parser.add_argument_group(
        "what was learned (--summary; no running stack, docs/explainer.md)"
    )
    learned.add_argument(
        "--summary",
        action="store_true",
        help="play --episodes scenes of --task-file in-process and print, per attribute value, "
        "the goals --policy sends those objects to, and how often (with --rules: agreement)",
    )
    learned.add_argument("--policy", help="with --summary: policy name or checkpoint file")
    learned.add_argument("--task-file", type=Path, help="with --summary: the task file to play")
    learned.add_argument(
        "--rules",
        type=Path,
        help="with --summary: rules file to judge the placements by (the policy never sees it; "
        "the expert teacher is told it)",
    )
    learned.add_argument(
        "--episodes", type=int, default=20, help="with --summary: scenes to play (default 20)"
    )
    learned.add_argument(
        "--accepts-filter",
        choices=["on", "off"],
        default="on",
        help="with --summary: a task policy's accepts filter (default on; docs/training.md)",
    )
    add_bus_arguments(parser)


_SUMMARY_ONLY = ("policy", "task_file", "rules")


def _run(args: argparse.Namespace) -> int:
    if args.seed < 0:
        raise ConfigError("seed", "must be >= 0")
    if args.summary:
        from manigraph_lab.explain_summary import run_summary

        return run_summary(args)
    for name in _SUMMARY_ONLY:
        if getattr(args, name) is not None:
            flag = "--" + name.replace("_", "-")
            raise ConfigError(name, f"{flag} goes with --summary (what a policy learned)")
    if (args.checkpoint is None) != (args.scene_from is None):
        raise ConfigError("checkpoint", "--checkpoint and --scene-from go together (offline)")
    if args.checkpoint is not None:
        explanation, note = explain_offline(
            args.checkpoint, args.scene_from, args.decision, args.seed
        )
        if note:
            print(note, file=sys.stderr)
    else:
        config = bus_config_from_args(args, wait_seconds=args.timeout)
        explanation = explain_online(config, args.decision, args.seed, args.timeout)
    if args.png is not None:
        from manigraph_lab.explain_viz import render_explanation

        render_explanation(explanation, args.png)
        print(f"wrote {args.png}", file=sys.stderr)
    if args.json:
        print(json.dumps(summary(explanation)), flush=True)
    else:
        print(explanation.sentence)
        for edge in explanation.edges:
            print(f"  edge {edge.src} -> {edge.dst}: {edge.weight:.3f}")
        for name, value in explanation.features.items():
            print(f"  feature {name}: {value:.3f}")
    return 0


command = Command(
    help="why did the planner choose that? explain its latest (or one) decision over Zenoh",
    configure=_configure,
    run=_run,
)
