"""Robot drivers: the swappable boundary between skills and a robot (sim or hardware)."""

from manigraph_skills.drivers import bus_gripper, franka, panda_sim  # noqa: F401  (register)
from manigraph_skills.drivers.base import DRIVERS, RobotDriver, create_driver, register_driver

__all__ = ["DRIVERS", "RobotDriver", "create_driver", "register_driver"]
