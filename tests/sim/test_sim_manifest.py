"""The sim's manifest says what each registered backend serves, and the backends agree."""

from __future__ import annotations

from manigraph_sim.geometric.backend import GeometricBackend
from manigraph_sim.manifest import MANIFEST
from manigraph_sim.physics.backend import PhysicsBackend


def test_each_backend_serves_exactly_the_abilities_its_manifest_variant_declares() -> None:
    assert GeometricBackend.abilities == MANIFEST.abilities("geometric")
    assert PhysicsBackend.abilities == MANIFEST.abilities("physics")
