"""The README and docs/*.md: generated blocks match the declarations, links resolve, and the
README stays a front door a newcomer reads in five minutes."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

from manigraph_tools.contract_doc import field_tables, key_table
from manigraph_tools.doc_blocks import Block, blocks, pages, refresh

ROOT = Path(__file__).resolve().parents[1]
README = ROOT / "README.md"
PAGES = pages(ROOT)
README_MAX_LINES = 180

#: [text](target) and ![alt](target); a target ends at the first space or closing bracket.
_LINK = re.compile(r"!?\[[^\]]*\]\(([^)\s]+)(?:\s+\"[^\"]*\")?\)")
_FENCE = re.compile(r"^```.*?^```", re.S | re.M)


def _id(page: Path) -> str:
    return str(page.relative_to(ROOT))


@pytest.mark.parametrize("page", PAGES, ids=_id)
def test_every_generated_block_matches_what_generates_it(page: Path) -> None:
    stale = [block.name for block in blocks(page.read_text()) if block.stale]
    assert not stale, (
        f"{_id(page)}: stale generated blocks {stale}; "
        "run `uv run python -m manigraph_tools.doc_blocks`"
    )


@pytest.mark.parametrize(
    ("page", "names"),
    [("README.md", {"keys"}), ("docs/contract.md", {"keys", "fields"})],
)
def test_the_contract_tables_are_where_readers_look_for_them(page: str, names: set[str]) -> None:
    assert names <= {block.name for block in blocks((ROOT / page).read_text())}


def test_a_stale_block_is_found_and_rewritten() -> None:
    text = "intro\n<!-- keys:start -->\n| old |\n<!-- keys:end -->\nafter\n"
    (block,) = blocks(text)
    assert block == Block("keys", "| old |\n", 26, 34) and block.stale
    fresh = refresh(text)
    assert fresh.startswith("intro\n<!-- keys:start -->\n| key expression (")
    assert fresh.endswith("|\n<!-- keys:end -->\nafter\n")
    assert not any(b.stale for b in blocks(fresh)) and refresh(fresh) == fresh


@pytest.mark.parametrize(
    ("text", "error"),
    [
        ("<!-- keys:start -->\n| x |\n", "'keys:start' is never closed"),
        ("| x |\n<!-- keys:end -->\n", "'keys:end' without 'keys:start'"),
        ("<!-- keys:start -->\n<!-- fields:start -->\n", "'fields:start' inside the open"),
    ],
)
def test_unbalanced_markers_are_refused(text: str, error: str) -> None:
    with pytest.raises(ValueError, match=error):
        blocks(text)


def test_an_unknown_block_name_is_refused() -> None:
    (block,) = blocks("<!-- nonsense:start -->\nx\n<!-- nonsense:end -->\n")
    with pytest.raises(ValueError, match="'nonsense' is not a generated block"):
        block.expected()


def test_the_readme_is_short() -> None:
    lines = len(README.read_text().splitlines())
    assert lines <= README_MAX_LINES, f"README.md has {lines} lines: move depth to docs/"


def test_readme_names_the_two_commands() -> None:
    text = README.read_text()
    assert "make up" in text and "make test" in text


def _slug(heading: str) -> str:
    """GitHub's anchor for a heading: lower case, punctuation dropped, spaces to hyphens."""
    text = re.sub(r"\[([^\]]*)\]\([^)]*\)", r"\1", heading.strip()).lower()  # a link: its text
    return re.sub(r"[^\w\- ]", "", text).replace(" ", "-")


def _anchors(page: Path) -> set[str]:
    text = _FENCE.sub("", page.read_text())
    return {_slug(m.group(1)) for m in re.finditer(r"^#{1,6}\s+(.+?)\s*$", text, re.M)}


def relative_links(page: Path) -> list[str]:
    """Every link target in ``page`` outside code blocks that is not a URL or a mail address."""
    text = _FENCE.sub("", page.read_text())
    return [
        target
        for target in _LINK.findall(text)
        if not re.match(r"^[a-z][a-z0-9+.-]*:", target)  # http:, https:, mailto: ...
    ]


def broken_links(page: Path) -> list[str]:
    """Relative links of ``page`` to a missing file, or to a missing heading of a page."""
    broken = []
    for target in relative_links(page):
        path, _, anchor = target.partition("#")
        resolved = (page.parent / path).resolve() if path else page
        if not resolved.exists():
            broken.append(f"{target} (no such file)")
        elif anchor and resolved.suffix == ".md" and anchor not in _anchors(resolved):
            broken.append(f"{target} (no such heading)")
    return broken


@pytest.mark.parametrize("page", PAGES, ids=_id)
def test_every_relative_link_resolves(page: Path) -> None:
    assert not broken_links(page), f"{_id(page)}: broken links {broken_links(page)}"


def test_the_link_check_sees_broken_links(tmp_path: Path) -> None:
    (tmp_path / "there.md").write_text("# A heading: with `code_name`\n")
    page = tmp_path / "page.md"
    page.write_text(
        "[ok](there.md#a-heading-with-code_name) [web](https://example.com) ![gone](gone.png)\n"
        "```\n[in code](nowhere.md)\n```\n[bad anchor](there.md#nope) [self](#a)\n"
    )
    assert broken_links(page) == [
        "gone.png (no such file)",
        "there.md#nope (no such heading)",
        "#a (no such heading)",
    ]


def test_the_key_table_shows_which_keys_are_per_cell_and_which_bus_wide() -> None:
    rows = [line for line in key_table().splitlines() if line.startswith("| `")]
    cells = {row.split(" | ")[0].strip("| `"): row.split(" | ")[4] for row in rows}
    assert cells["manigraph/<cell>/world/scene"] == "per cell"
    assert cells["manigraph/<cell>/status/{service}"] == "per cell"
    assert cells["manigraph/<cell>/alive/<service>"] == "per cell"
    assert cells["manigraph/**"] == "bus-wide"
    assert set(cells.values()) == {"per cell", "bus-wide"}
    assert all(key.startswith("manigraph/<cell>/") for key, c in cells.items() if c == "per cell")
    assert "the default cell has no `<cell>/`" in key_table().splitlines()[0]
    assert "**`Scene`** (`manigraph/<cell>/world/scene`)" in field_tables()
