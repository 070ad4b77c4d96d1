"""The physics backend: a SAPIEN 3 world with the Franka Panda from the mani-skill package.

Registered here without importing SAPIEN, so ``manigraph sim --backend geometric`` stays fast;
SAPIEN is imported when a physics backend is created.
"""

from __future__ import annotations

from manigraph_sim.backend import SimBackend, register_backend


@register_backend("physics")
def create_physics_backend(**options: object) -> SimBackend:
    from manigraph_sim.physics.backend import PhysicsBackend

    return PhysicsBackend(**options)  # type: ignore[arg-type]
