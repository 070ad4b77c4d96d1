"""Robot drivers: the swappable boundary between skills and a robot (sim or hardware)."""

from manigraph_skills.drivers.base import Motion, RobotDriver
from manigraph_skills.drivers.registry import DRIVERS, create_driver

__all__ = ["DRIVERS", "Motion", "RobotDriver", "create_driver"]
