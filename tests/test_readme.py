"""The README's contract table is generated from the declarations; it must not drift."""

from __future__ import annotations

import re
from pathlib import Path

from manigraph_tools.contract_doc import field_tables, flow_diagram, key_table

README = Path(__file__).resolve().parents[1] / "README.md"


def test_readme_key_table_matches_the_message_declarations() -> None:
    text = README.read_text()
    block = re.search(r"<!-- keys:start -->\n(.*?)\n<!-- keys:end -->", text, re.S)
    assert block is not None, "README lost its keys:start/keys:end markers"
    assert block.group(1).strip() == key_table().strip(), "run `manigraph keys` and paste it"


def test_readme_field_tables_match_the_message_declarations() -> None:
    text = README.read_text()
    block = re.search(r"<!-- fields:start -->\n(.*?)\n<!-- fields:end -->", text, re.S)
    assert block is not None, "README lost its fields:start/fields:end markers"
    assert block.group(1).strip() == field_tables().strip(), "run `manigraph keys --fields`"


def test_readme_names_the_two_commands() -> None:
    text = README.read_text()
    assert "make up" in text and "make test" in text


def test_readme_flow_diagram_matches_the_service_manifests() -> None:
    text = README.read_text()
    block = re.search(r"<!-- flow:start -->\n```mermaid\n(.*?)\n```\n<!-- flow:end -->", text, re.S)
    assert block is not None, "README lost its flow:start/flow:end markers"
    assert block.group(1).strip() == flow_diagram().strip(), "run `manigraph keys --flow`"
