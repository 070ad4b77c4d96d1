"""Access control per robot cell: each cell identity is granted its service's rows on its own
cells' keys, and nothing in any other cell or in the default cell."""

from __future__ import annotations

from pathlib import Path

import pytest

from manigraph_shared.cells import cell_key
from manigraph_shared.errors import ConfigError
from manigraph_shared.messages import Action, EpisodeRequest, RobotCommand, Scene
from manigraph_tools.access import (
    access_control,
    cell_identities,
    read_cell_identities,
    write_cell_identities,
)

CELLS = {**cell_identities(["cell-1", "cell-2"]), "planner.pool": ("cell-1", "cell-2")}


def allowed(message: str, key: str, cells: dict[str, tuple[str, ...]] = CELLS) -> set[str]:
    """Identities the policy lets send ``message`` on exactly ``key``."""
    config = access_control(cells=cells)
    rules = {
        rule["id"]
        for rule in config["rules"]  # type: ignore[attr-defined]
        if message in rule["messages"] and rule["flows"] == ["ingress"] and key in rule["key_exprs"]
    }
    return {
        subject
        for policy in config["policies"]  # type: ignore[attr-defined]
        if set(policy["rules"]) & rules
        for subject in policy["subjects"]
    }


@pytest.mark.parametrize(
    ("kind", "key", "cell", "who"),
    [
        ("put", RobotCommand.key, "cell-1", {"skills.cell-1"}),
        ("put", RobotCommand.key, "cell-2", {"skills.cell-2"}),
        ("put", Scene.key, "cell-1", {"sim.cell-1", "perception.cell-1"}),
        ("put", Action.key, "cell-1", {"planner.cell-1", "demo-ui.cell-1", "planner.pool"}),
        ("put", Action.key, "cell-2", {"planner.cell-2", "demo-ui.cell-2", "planner.pool"}),
        ("query", EpisodeRequest.key, "cell-2", {"client.cell-2", "demo-ui.cell-2"}),
        ("declare_queryable", EpisodeRequest.key, "cell-1", {"sim.cell-1"}),
        (
            "liveliness_token",
            "manigraph/alive/planner",
            "cell-2",
            {"planner.cell-2", "planner.pool"},
        ),
        ("put", "manigraph/status/sim", "cell-1", {"sim.cell-1"}),
    ],
)
def test_a_cell_key_is_granted_to_that_cells_identities_only(
    kind: str, key: str, cell: str, who: set[str]
) -> None:
    assert allowed(kind, cell_key(key, cell)) == who


def test_the_default_cells_keys_stay_with_the_bare_identities() -> None:
    assert allowed("put", RobotCommand.key) == {"skills"}
    assert allowed("query", EpisodeRequest.key) == {"client", "demo-ui"}


def test_routers_relay_every_message_and_others_read_only() -> None:
    cells = {**CELLS, "router.site-b": ()}
    assert allowed("put", "manigraph/**", cells) == {"router", "router.site-b"}
    readers = allowed("declare_subscriber", "manigraph/**", cells)
    assert {"sim.cell-1", "planner.pool", "client.cell-2", "router.site-b"} <= readers


def test_the_cells_file_round_trips_and_rejects_nonsense(tmp_path: Path) -> None:
    assert read_cell_identities(tmp_path) == {}
    write_cell_identities(tmp_path, {**CELLS, "router.site-a": ()})
    assert read_cell_identities(tmp_path) == {**CELLS, "router.site-a": ()}
    with pytest.raises(ConfigError, match="serves no cell"):
        write_cell_identities(tmp_path, {"planner.pool": ()})
    with pytest.raises(ConfigError, match=r"not <service>\.<cell or label>"):
        write_cell_identities(tmp_path, {"robot.cell-1": ("cell-1",)})
    with pytest.raises(ConfigError, match="not a cell name"):
        write_cell_identities(tmp_path, {"sim.cell-1": ("Cell 1",)})
    (tmp_path / "cells.json").write_text("[1, 2]")
    with pytest.raises(ConfigError, match="not a cells file"):
        read_cell_identities(tmp_path)
