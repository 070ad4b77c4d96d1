"""The Franka Panda on real hardware: the boundary where the hardware driver plugs in.

Not implemented yet: it refuses to start with a message saying so, rather than pretending to
move a robot. The swap to it (``--driver franka``, compose profile ``hardware``) already works.
"""

from __future__ import annotations

from manigraph_shared.errors import ConfigError
from manigraph_shared.messages import Quaternion, Vector3
from manigraph_skills.drivers.base import CENTRE_GRASP, Grasp, RobotDriver, register_driver


@register_driver("franka")
class FrankaDriver(RobotDriver):
    def __init__(self, **_options: object) -> None:
        raise ConfigError(
            "driver",
            "the Franka hardware driver is not implemented yet; use --driver sim-gripper "
            "with the sim service",
        )

    def pick(
        self,
        decision_id: str,
        object_id: str,
        position: Vector3,
        orientation: Quaternion,
        grasp: Grasp = CENTRE_GRASP,
    ) -> None:
        raise NotImplementedError

    def place(
        self,
        decision_id: str,
        object_id: str,
        position: Vector3,
        orientation: Quaternion,
        grasp: Grasp = CENTRE_GRASP,
    ) -> None:
        raise NotImplementedError

    def stop(self) -> None:
        raise NotImplementedError

    def resume(self) -> None:
        raise NotImplementedError
