"""``manigraph certs``: make the local CA and the certificates of every bus identity."""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

from manigraph_shared.cli import Command
from manigraph_tools.access import access_control, policy_table
from manigraph_tools.certs import DEFAULT_DAYS, IDENTITIES, CertificateSet, make_certificates


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


def _run(args: argparse.Namespace) -> int:
    if args.policy == "markdown":
        print(policy_table())
        return 0
    if args.policy == "json":
        print(json.dumps(access_control(), indent=2))
        return 0
    if args.keep_existing and CertificateSet(args.out, tuple(args.identity)).complete():
        print(f"certificates in {args.out} already exist; kept", file=sys.stderr)
        return 0
    made = make_certificates(
        args.out, args.identity, hosts=args.host, days=args.days, force=args.force
    )
    print(
        f"wrote a CA ({made.ca}) and certificates for {', '.join(made.identities)} "
        f"to {args.out}/ (valid {args.days} days; keys are mode 0600)",
        file=sys.stderr,
    )
    return 0


certs_command = Command(
    help="make a local CA and one TLS certificate per bus identity (router, sim, planner, ...)",
    configure=_configure,
    run=_run,
)
