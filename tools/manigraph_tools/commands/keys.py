"""`manigraph keys`: the contract's key table, fields and flow diagram."""

from __future__ import annotations

import argparse

from manigraph_shared.cli import Command
from manigraph_tools import contract_doc


def _keys_configure(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--fields", action="store_true", help="also print every message's fields")
    parser.add_argument(
        "--flow", action="store_true", help="print the services' flow diagram (Mermaid) instead"
    )


def _keys_run(args: argparse.Namespace) -> int:
    if args.flow:
        print(contract_doc.flow_diagram())
        return 0
    print(contract_doc.key_table())
    if args.fields:
        print()
        print(contract_doc.field_tables())
    return 0


command = Command(
    help="print the key expression / message table (Markdown, as in the README)",
    configure=_keys_configure,
    run=_keys_run,
)
