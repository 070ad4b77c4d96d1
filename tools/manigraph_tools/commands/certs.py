"""``manigraph certs``: make the local CA and the certificates of every bus identity."""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

from manigraph_shared.cli import Command
from manigraph_shared.errors import ConfigError
from manigraph_tools.access import (
    access_control,
    cell_identities,
    check_cell_identities,
    policy_table,
    read_cell_identities,
    write_cell_identities,
)
from manigraph_tools.certificates import DEFAULT_DAYS, IDENTITIES, CertificateSet, make_certificates


def _configure(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "-o", "--out", type=Path, default=Path("certs"), help="directory (default: certs/)"
    )
    parser.add_argument(
        "--identity",
        nargs="+",
        default=list(IDENTITIES),
        help=f"identities to certify (default: {' '.join(IDENTITIES)})",
    )
    parser.add_argument(
        "--host",
        nargs="+",
        default=[],
        help="extra DNS names or IP addresses every certificate is valid for (e.g. the "
        "router's address on your network); each identity's own name, localhost and "
        "127.0.0.1 are always included",
    )
    parser.add_argument(
        "--cells",
        help="robot cells a,b,...: also a certificate per cell for each of its services "
        "(sim.a, skills.a, planner.a, client.a, ...), granted that cell's keys only, and "
        "cells.json for the router (docs/scaling.md)",
    )
    parser.add_argument(
        "--serve",
        action="append",
        default=[],
        metavar="IDENTITY=CELL,CELL",
        help="an identity acting in several cells, e.g. planner.gpu=a,b (one planner for "
        "many cells); repeatable",
    )
    parser.add_argument("--days", type=int, default=DEFAULT_DAYS, help="validity (default 365)")
    parser.add_argument("--force", action="store_true", help="replace an existing set")
    parser.add_argument(
        "--keep-existing",
        action="store_true",
        help="do nothing if every file already exists (compose's one-shot certs service)",
    )
    parser.add_argument(
        "--policy",
        choices=["markdown", "json"],
        help="print the router's access-control policy instead (Markdown table or Zenoh JSON)",
    )


def _in_cells(args: argparse.Namespace) -> dict[str, tuple[str, ...]]:
    """Identity -> its cells, from --cells, --serve and dotted --identity names (routers)."""
    cells = [c.strip() for c in (args.cells or "").split(",") if c.strip()]
    wanted: dict[str, tuple[str, ...]] = cell_identities(cells)
    for item in args.serve:
        identity, sep, served = item.partition("=")
        if not sep:
            raise ConfigError("serve", f"'{item}' is not IDENTITY=CELL,CELL")
        wanted[identity] = tuple(c.strip() for c in served.split(",") if c.strip())
    for identity in args.identity:
        if "." in identity and identity not in wanted:
            wanted[identity] = ()
    return check_cell_identities(wanted)


def _run(args: argparse.Namespace) -> int:
    in_cells = _in_cells(args)
    if args.policy == "markdown":
        print(policy_table())
        return 0
    if args.policy == "json":
        cells = in_cells or read_cell_identities(args.out if args.out.is_dir() else None)
        print(json.dumps(access_control(cells=cells), indent=2))
        return 0
    identities = list(dict.fromkeys([*args.identity, *in_cells]))
    if args.keep_existing and CertificateSet(args.out, tuple(identities)).complete():
        print(f"certificates in {args.out} already exist; kept", file=sys.stderr)
        return 0
    made = make_certificates(
        args.out, identities, hosts=args.host, days=args.days, force=args.force
    )
    if in_cells:
        write_cell_identities(args.out, in_cells)
    print(
        f"wrote a CA ({made.ca}) and certificates for {', '.join(made.identities)} "
        f"to {args.out}/ (valid {args.days} days; keys are mode 0600)",
        file=sys.stderr,
    )
    return 0


command = Command(
    help="make a local CA and one TLS certificate per bus identity (router, sim, planner, ...)",
    configure=_configure,
    run=_run,
)
