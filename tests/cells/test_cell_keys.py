"""Cell names and keys: a cell is the key's second segment; the default cell has none."""

from __future__ import annotations

import argparse

import pytest

from manigraph_shared.bus_config import BusConfig, add_bus_arguments, bus_config_from_args
from manigraph_shared.cells import (
    RESERVED,
    cell_key,
    cell_names,
    cell_of,
    check_cell,
    check_cells,
    default_key,
)
from manigraph_shared.errors import ConfigError
from manigraph_shared.messages import Message


def test_a_key_moves_into_its_cell_and_back() -> None:
    assert cell_key("manigraph/world/scene", "left") == "manigraph/left/world/scene"
    assert cell_key("manigraph/camera/*/image", "left") == "manigraph/left/camera/*/image"
    assert cell_of("manigraph/left/world/scene") == "left"


def test_the_default_cell_keeps_todays_keys() -> None:
    assert cell_key("manigraph/world/scene", None) == "manigraph/world/scene"
    assert cell_of("manigraph/world/scene") is None
    assert cell_key("other/world/scene", "left") == "other/world/scene"  # not manigraph's


def test_every_declared_key_is_told_apart_from_a_cell() -> None:
    for message_type in Message.registry.values():
        segment = message_type.key.split("/")[1]
        assert segment in RESERVED, message_type.key
        assert cell_of(message_type.key_pattern()) is None


@pytest.mark.parametrize("name", ["", "Left", "-a", "a/b", "a*", "x" * 33, "world", "alive"])
def test_a_bad_cell_name_is_refused_naming_the_field(name: str) -> None:
    with pytest.raises(ConfigError, match="cell"):
        check_cell(name)
    with pytest.raises(ConfigError, match="cell"):
        BusConfig(cell=name or "-")


def test_up_names_its_cells_and_refuses_none() -> None:
    assert cell_names(3) == ["cell-1", "cell-2", "cell-3"]
    with pytest.raises(ConfigError, match="cells"):
        cell_names(0)


def test_the_cell_comes_from_the_flag_or_the_environment() -> None:
    parser = argparse.ArgumentParser()
    add_bus_arguments(parser)
    env = {"MANIGRAPH_CELL": "right"}
    assert bus_config_from_args(parser.parse_args([]), environ=env).cell == "right"
    assert bus_config_from_args(parser.parse_args(["--cell", "left"]), environ=env).cell == "left"
    assert bus_config_from_args(parser.parse_args([]), environ={"MANIGRAPH_CELL": ""}).cell is None


def test_a_cells_key_goes_back_to_the_key_its_type_is_declared_on() -> None:
    assert default_key("manigraph/left/world/scene") == "manigraph/world/scene"
    assert default_key("manigraph/left/status/planner") == "manigraph/status/planner"
    assert default_key("manigraph/world/scene") == "manigraph/world/scene"


@pytest.mark.parametrize("names", [[], ["left", "Left"], ["a", "b", "a"], ["world"]])
def test_a_bad_list_of_cells_is_refused_naming_cells(names: list[str]) -> None:
    with pytest.raises(ConfigError, match=r"^cells: "):
        check_cells(names)
    assert check_cells(["a", "b"]) == ["a", "b"]
