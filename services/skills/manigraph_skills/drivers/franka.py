"""The Franka Panda on real hardware: the boundary where the hardware driver plugs in.

Not implemented yet: it refuses to start with a message saying so, rather than pretending to
move a robot. The swap to it (``--driver franka``, compose profile ``hardware``) already works.
"""

from __future__ import annotations

from typing import Any

from manigraph_shared.errors import ConfigError
from manigraph_skills.drivers.base import Motion, RobotDriver


class FrankaDriver(RobotDriver):
    name = "franka"

    def __init__(self, **_options: Any) -> None:
        raise ConfigError(
            "driver",
            "the Franka hardware driver is not implemented yet; use --driver sim-gripper "
            "with the sim service",
        )

    def pick(self, motion: Motion) -> None:
        raise NotImplementedError

    def place(self, motion: Motion) -> None:
        raise NotImplementedError

    def stop(self) -> None:
        raise NotImplementedError

    def resume(self) -> None:
        raise NotImplementedError
