"""A task family without a physics world need not define one (``SimFamily.physics_world``):
the physics backend is refused its episodes, naming the family, not an ``AbstractMethodError``
at registration."""

from __future__ import annotations

from typing import Any

import pytest

from manigraph_shared.errors import ConfigError
from manigraph_sim.family import Evaluation, GeometricTaskWorld, SimFamily


class FlatFamily(SimFamily):
    """A family with only a geometric world (what a new family may start with)."""

    name = "flat"

    def evaluate(self, layout: Any, world: Any) -> Evaluation:
        return Evaluation(frozenset(), frozenset(), success=False)

    def geometric_world(self, layout: Any, goal_tolerance: float) -> GeometricTaskWorld:
        raise NotImplementedError


def test_a_family_without_a_physics_world_is_refused_by_name() -> None:
    family = FlatFamily()  # instantiable: physics_world is not abstract
    with pytest.raises(ConfigError, match=r"backend: the flat family has no physics world") as e:
        family.physics_world(None, lambda bodies: None, 0.01)  # type: ignore[arg-type,return-value]
    assert e.value.field == "backend"
