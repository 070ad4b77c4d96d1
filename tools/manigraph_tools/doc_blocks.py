"""Generated blocks in the README and ``docs/*.md``: found, checked and rewritten in place.

A block is delimited by ``<!-- NAME:start -->`` and ``<!-- NAME:end -->`` lines; its body is
whatever :data:`GENERATORS` ``[NAME]`` returns, so a table built from the declarations can
never drift from them (``tests/test_readme.py`` checks every block of every page). After a
change to the declarations, rewrite them all::

    uv run python -m manigraph_tools.doc_blocks          # rewrite README.md and docs/*.md
    uv run python -m manigraph_tools.doc_blocks --check  # exit 1 if any block is stale
"""

from __future__ import annotations

import argparse
import re
import sys
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

from manigraph_tools.access import policy_table
from manigraph_tools.contract_doc import field_tables, flow_block, key_table
from manigraph_tools.registry_doc import registry_table

#: Block name -> the Markdown it holds. A new generated block registers its generator here.
GENERATORS: dict[str, Callable[[], str]] = {
    "keys": key_table,
    "fields": field_tables,
    "flow": flow_block,
    "policy-table": policy_table,
    "registries": registry_table,
}

_MARKER = re.compile(r"^<!-- ([a-z][a-z0-9-]*):(start|end) -->$", re.M)


@dataclass(frozen=True)
class Block:
    name: str
    body: str
    start: int  # offset of the body in the page's text
    end: int

    def expected(self) -> str:
        if self.name not in GENERATORS:
            known = ", ".join(sorted(GENERATORS))
            raise ValueError(f"'{self.name}' is not a generated block (known: {known})")
        return GENERATORS[self.name]().strip()

    @property
    def stale(self) -> bool:
        return self.body.strip() != self.expected()


def blocks(text: str) -> list[Block]:
    """Every generated block of a page; ValueError on a marker without its partner."""
    found: list[Block] = []
    opened: tuple[str, int] | None = None
    for marker in _MARKER.finditer(text):
        name, side = marker.groups()
        if side == "start":
            if opened is not None:
                raise ValueError(f"'{name}:start' inside the open block '{opened[0]}'")
            opened = (name, marker.end() + 1)
        else:
            if opened is None or opened[0] != name:
                raise ValueError(f"'{name}:end' without '{name}:start'")
            found.append(Block(name, text[opened[1] : marker.start()], opened[1], marker.start()))
            opened = None
    if opened is not None:
        raise ValueError(f"'{opened[0]}:start' is never closed")
    return found


def refresh(text: str) -> str:
    """``text`` with every generated block's body regenerated."""
    for block in reversed(blocks(text)):
        text = text[: block.start] + block.expected() + "\n" + text[block.end :]
    return text


def pages(root: Path) -> list[Path]:
    """The pages that may hold generated blocks: README.md and docs/*.md."""
    return [root / "README.md", *sorted((root / "docs").glob("*.md"))]


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0] if __doc__ else None)
    parser.add_argument("--root", type=Path, default=Path.cwd(), help="repository root")
    parser.add_argument("--check", action="store_true", help="only report stale blocks")
    args = parser.parse_args(argv)
    stale = []
    for page in pages(args.root):
        text = page.read_text()
        fresh = refresh(text)
        if fresh != text:
            stale.append(page)
            if not args.check:
                page.write_text(fresh)
    verb = "stale" if args.check else "rewrote"
    for page in stale:
        print(f"{verb}: {page}", file=sys.stderr)
    return 1 if args.check and stale else 0


if __name__ == "__main__":
    sys.exit(main())
