"""``manigraph explain-faithfulness``: how faithful the explanations are
(:mod:`manigraph_lab.faithfulness_study`, docs/explainer-faithfulness.md)."""

from __future__ import annotations

import argparse
from pathlib import Path

from manigraph_shared.cli import Command


def _faithfulness_configure(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "--checkpoints",
        type=Path,
        nargs="+",
        default=[Path(f"checkpoints/{arch}.pt") for arch in ("gcn", "sage", "gated", "gat")],
        help="policies whose decisions are explained (name: the file's stem)",
    )
    parser.add_argument("--decisions", type=int, default=100, help="decisions per task and policy")
    parser.add_argument(
        "--objectives",
        nargs="+",
        default=["distribution", "pair-context"],
        help="explainer objectives to compare (distribution, pair, pair-context)",
    )
    parser.add_argument("-o", "--out", type=Path, help="also write the table to this file")


def _faithfulness_run(args: argparse.Namespace) -> int:
    from manigraph_lab.faithfulness_study import run, table
    from manigraph_planner.explain.config import ExplainerConfig

    for objective in args.objectives:
        ExplainerConfig(objective=objective)  # a bad name stops here, naming the field
    cells = run({p.stem: p for p in args.checkpoints}, args.decisions, tuple(args.objectives))
    text = table(cells)
    if args.out is not None:
        args.out.parent.mkdir(parents=True, exist_ok=True)
        args.out.write_text(text + "\n")
    print(text)
    return 0


command = Command(
    help="how faithful are the explanations: PyG fidelity+/- and top-edge rate per objective",
    configure=_faithfulness_configure,
    run=_faithfulness_run,
)
