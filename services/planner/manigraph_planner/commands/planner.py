"""``manigraph planner``: entry point (torch is imported only when a GNN policy is served)."""

from __future__ import annotations

import argparse
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Literal

from manigraph_shared.bus_config import add_bus_arguments, bus_config_from_args
from manigraph_shared.cli import Command
from manigraph_shared.options import Interval, Options, add_option_arguments, option

if TYPE_CHECKING:
    from manigraph_planner.policies.base import Policy
    from manigraph_shared.bus import Bus


@dataclass(frozen=True)
class PlannerOptions(Options):
    policy: str = option(
        "expert", help="registered policy name (expert) or policy file (a .pt checkpoint)"
    )
    explain_decisions: bool = option(
        False,
        help="publish an Explanation after every decision (GNN policies; lands in the log)",
    )
    decision_timeout: float = option(
        30.0,
        help="wait this long for a decision's final skill status before giving it up (a lost "
        "skills service is noticed at once)",
        within=Interval(0, 3600, low_open=True),
        unit="s",
    )
    accepts_filter: Literal["on", "off"] = option(
        "on",
        help="a policy learned from a task file takes only pairs whose goal accepts the object "
        "(on); off: the network's own choice, to measure what it learned (docs/training.md)",
    )
    rules: Path | None = option(
        None,
        help="rules only the teacher and the judge know (docs/task-files.md): the expert "
        "decides by them; a learned policy is refused them",
    )
    cells: str | None = option(
        None,
        help="serve these robot cells, comma-separated (cell-1,cell-2): one planner thread "
        "per cell sharing the loaded policy (docs/scaling.md); default: the one cell of --cell",
    )

    def cell_list(self) -> list[str] | None:
        """The cells of ``--cells``, checked; None without it."""
        if self.cells is None:
            return None
        from manigraph_shared.cells import check_cells

        return check_cells([name.strip() for name in self.cells.split(",")])


def _configure(parser: argparse.ArgumentParser) -> None:
    add_option_arguments(parser, PlannerOptions)
    add_bus_arguments(parser)


def _told_the_rules(policy: Policy, path: Path) -> Policy:
    """``policy`` deciding by the rules file at ``path`` (``ConfigError`` naming ``rules``)."""
    from manigraph_planner.policies.teacher_rules import with_rules
    from manigraph_shared.errors import ConfigError, PolicyError

    try:
        text = path.read_text()
    except (OSError, UnicodeDecodeError) as exc:
        raise ConfigError("rules", f"cannot read {path}: {exc}") from None
    try:
        return with_rules(policy, text, str(path))
    except PolicyError as exc:
        raise ConfigError("rules", str(exc).removeprefix("rules: ")) from exc


def _run(args: argparse.Namespace) -> int:
    from manigraph_planner.policies import POLICIES, load_policy
    from manigraph_planner.service import PlannerService
    from manigraph_shared.errors import ConfigError, PolicyError
    from manigraph_shared.options import options_from_args
    from manigraph_shared.service import run_service
    from manigraph_shared.service_facts import checkpoint_of

    options = options_from_args(PlannerOptions, args)
    cells = options.cell_list()  # a bad cell name stops here, before torch is imported
    bus_config = bus_config_from_args(args)
    if cells is not None and bus_config.cell is not None:
        raise ConfigError("cells", "give --cells or --cell, not both")
    try:
        policy = load_policy(options.policy, accepts_filter=options.accepts_filter)
    except PolicyError as exc:  # a missing or unreadable policy: restarting cannot help
        if str(exc).startswith("accepts-filter:"):
            raise ConfigError("accepts-filter", str(exc).removeprefix("accepts-filter: ")) from exc
        raise ConfigError("policy", str(exc).removeprefix("policy: ")) from exc
    if options.rules is not None:
        policy = _told_the_rules(policy, options.rules)
    if options.explain_decisions:
        from manigraph_planner.policies.gnn import GNNPolicy

        if not isinstance(policy, GNNPolicy):
            raise ConfigError(
                "explain-decisions",
                f"only GNN policies can be explained, not '{policy.name}' (give a checkpoint)",
            )
    registered = options.policy in POLICIES
    checkpoint = None if registered else checkpoint_of(Path(options.policy))
    if cells is None:
        return run_service(
            lambda bus: PlannerService(
                bus,
                policy,
                options.explain_decisions,
                decision_timeout=options.decision_timeout,
                checkpoint=checkpoint,
            ),
            bus_config,
        )
    from manigraph_shared.cell_services import run_cell_services

    def planner_of(bus: Bus, _cell: str | None) -> PlannerService:
        return PlannerService(
            bus,
            policy,
            options.explain_decisions,
            decision_timeout=options.decision_timeout,
            decide_on_arrival=len(cells) == 1,
            checkpoint=checkpoint,
        )

    return run_cell_services(planner_of, bus_config, cells)


command = Command(help="run the planner service (policy -> Action)", configure=_configure, run=_run)
