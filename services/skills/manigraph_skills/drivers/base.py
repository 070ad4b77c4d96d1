"""What a skill needs from a robot: grasp an object at a pose, release it at another."""

from __future__ import annotations

from abc import ABC, abstractmethod
from collections.abc import Callable

from manigraph_shared.errors import ConfigError
from manigraph_shared.messages import Quaternion, Vector3


class RobotDriver(ABC):
    """Raises ``SkillError(reason)`` when the robot could not do what was asked."""

    name: str

    @abstractmethod
    def pick(
        self, decision_id: str, object_id: str, position: Vector3, orientation: Quaternion
    ) -> None:
        """Grasp ``object_id`` whose centre is at ``position`` and lift it clear."""

    @abstractmethod
    def place(
        self, decision_id: str, object_id: str, position: Vector3, orientation: Quaternion
    ) -> None:
        """Carry the held object so its centre is at ``position`` and release it."""

    def close(self) -> None:
        """Release the driver's resources."""


DRIVERS: dict[str, Callable[..., RobotDriver]] = {}


def register_driver(name: str) -> Callable[[type[RobotDriver]], type[RobotDriver]]:
    def register(cls: type[RobotDriver]) -> type[RobotDriver]:
        cls.name = name
        DRIVERS[name] = cls
        return cls

    return register


def create_driver(name: str, **options: object) -> RobotDriver:
    if name not in DRIVERS:
        raise ConfigError("driver", f"'{name}' is not one of {', '.join(sorted(DRIVERS))}")
    return DRIVERS[name](**options)
