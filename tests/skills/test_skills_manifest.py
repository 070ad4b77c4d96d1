"""The skills manifest names every registered robot driver, and nothing else."""

from __future__ import annotations

from manigraph_skills.drivers import DRIVERS
from manigraph_skills.manifest import MANIFEST


def test_manifest_variants_are_the_registered_drivers() -> None:
    assert set(MANIFEST.variants) == set(DRIVERS)


def test_driver_auto_follows_the_sim_backend_variable() -> None:
    from manigraph_skills.commands.skills import auto_driver

    assert auto_driver({"MANIGRAPH_SIM_BACKEND": "physics"}) == "panda-sim"
    assert auto_driver({"MANIGRAPH_SIM_BACKEND": "geometric"}) == "sim-gripper"
    assert auto_driver({}) == "sim-gripper"  # the sim's own default backend
