"""Service manifests: gated ports, driver matching, and the flow diagram drawn from them."""

from __future__ import annotations

import pytest

from manigraph_shared.errors import ConfigError
from manigraph_shared.manifest import (
    WORLD_ABILITIES,
    Manifest,
    driver_for_backend,
    driver_for_world,
    load_manifests,
    mermaid_flow,
    port,
)
from manigraph_shared.messages import Action, JointState, RobotCommand, Scene


def test_every_service_and_tool_declares_a_manifest() -> None:
    assert {"sim", "planner", "skills", "perception", "recorder", "run"} <= set(load_manifests())


@pytest.mark.parametrize(
    ("backend", "driver"), [("geometric", "sim-gripper"), ("physics", "panda-sim")]
)
def test_up_matches_the_skills_driver_to_what_the_sim_backend_offers(
    backend: str, driver: str
) -> None:
    manifests = load_manifests()
    assert driver_for_world(manifests["sim"], backend, manifests["skills"]) == driver


def test_a_driver_no_world_offers_is_never_picked_and_no_match_is_an_error() -> None:
    world = Manifest("w", "w", produces=(port(Scene),), variants={"toy": frozenset({"a"})})
    robot = Manifest("r", "r", variant_option="driver", variants={"real": frozenset({"b"})})
    with pytest.raises(ConfigError, match="driver: no r driver needs only what w 'toy' offers"):
        driver_for_world(world, "toy", robot)
    with pytest.raises(ConfigError, match="'nope' is not one of toy"):
        driver_for_world(world, "nope", robot)


def test_a_port_gated_by_an_undeclared_ability_is_refused() -> None:
    with pytest.raises(ConfigError, match=r"x\.manifest: port manigraph/<cell>/robot/joint_state"):
        Manifest("x", "x", produces=(port(JointState, "joints"),))


def test_flow_draws_an_arrow_from_each_producer_to_each_consumer_dotted_when_gated() -> None:
    world = Manifest(
        "world",
        "w",
        produces=(port(Scene),),
        consumes=(port(RobotCommand, "grip"),),
        variants={"v": frozenset({"grip"})},
    )
    brain = Manifest("brain", "b", consumes=(port(Scene),), produces=(port(Action),))
    hand = Manifest(
        "hand",
        "h",
        consumes=(port(Action),),
        produces=(port(RobotCommand, "grip"),),
        variants={"d": frozenset({"grip"})},
    )
    flow = mermaid_flow([world, brain, hand])
    assert 'WORLD -- "manigraph/#lt;cell#gt;/world/scene" --> BRAIN' in flow
    assert 'BRAIN -- "manigraph/#lt;cell#gt;/planner/action" --> HAND' in flow
    assert 'HAND -. "manigraph/#lt;cell#gt;/robot/command (grip)" .-> WORLD' in flow
    assert "HAND -- " not in flow.replace('HAND -. "', "")  # the gated edge only, dotted


def test_without_the_sim_installed_the_contract_table_matches_the_driver() -> None:
    # The skills container has no sim package; the world abilities are part of the contract.
    manifests = load_manifests()
    assert manifests["sim"].variants == dict(WORLD_ABILITIES)
    without_sim = {name: m for name, m in manifests.items() if name != "sim"}
    assert driver_for_backend("physics", without_sim) == "panda-sim"
    assert driver_for_backend("geometric", without_sim) == "sim-gripper"


def test_ports_and_the_flow_show_each_key_with_its_cell_segment() -> None:
    """A service runs in one robot cell (``--cell``), so its manifest's keys are per cell;
    the recorder and the viewer read every cell (the one bus-wide key expression)."""
    assert port(Scene).key == "manigraph/<cell>/world/scene"
    watcher = Manifest("watcher", "w", observes_all=True)
    world = Manifest("world", "w", produces=(port(Scene),))
    brain = Manifest("brain", "b", consumes=(port(Scene),))
    flow = mermaid_flow([world, brain, watcher])
    # Mermaid takes a bare <cell> for an HTML tag and drops it: its entity codes print it.
    assert 'WORLD -- "manigraph/#lt;cell#gt;/world/scene" --> BRAIN' in flow
    assert "<cell>" not in flow
    assert 'WORLD -- "manigraph/** (every cell)" --> WATCHER' in flow
