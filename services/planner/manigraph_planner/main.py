"""``manigraph planner``: entry point (torch is imported only when a GNN policy is served)."""

from __future__ import annotations

import argparse

from manigraph_shared.bus_config import add_bus_arguments, bus_config_from_args
from manigraph_shared.cli import Command


def _configure(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "--policy", default="expert", help="registered policy name or checkpoint path"
    )
    parser.add_argument(
        "--explain-decisions",
        action="store_true",
        help="publish an Explanation after every decision (GNN policies; lands in the log)",
    )
    parser.add_argument(
        "--decision-timeout",
        type=float,
        default=30.0,
        help="seconds to wait for a decision's final skill status before giving it up "
        "(default 30; a lost skills service is noticed at once)",
    )
    add_bus_arguments(parser)


def _run(args: argparse.Namespace) -> int:
    from manigraph_planner.policies import load_policy
    from manigraph_planner.service import PlannerService
    from manigraph_shared.errors import ConfigError
    from manigraph_shared.service import run_service

    if not 0 < args.decision_timeout <= 3600:
        raise ConfigError("decision-timeout", "must be in (0, 3600] seconds")
    policy = load_policy(args.policy)
    if args.explain_decisions:
        from manigraph_planner.policies.gnn import GNNPolicy

        if not isinstance(policy, GNNPolicy):
            raise ConfigError(
                "explain-decisions",
                f"only GNN policies can be explained, not '{policy.name}' (give a checkpoint)",
            )
    return run_service(
        lambda bus: PlannerService(
            bus, policy, args.explain_decisions, decision_timeout=args.decision_timeout
        ),
        bus_config_from_args(args),
    )


command = Command(help="run the planner service (policy -> Action)", configure=_configure, run=_run)
