"""The skills manifest names every registered robot driver, and nothing else."""

from __future__ import annotations

from manigraph_skills.drivers import DRIVERS
from manigraph_skills.manifest import MANIFEST


def test_manifest_variants_are_the_registered_drivers() -> None:
    assert set(MANIFEST.variants) == set(DRIVERS)
