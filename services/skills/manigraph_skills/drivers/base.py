"""What a skill needs from a robot: grasp an object at a pose, release it at another."""

from __future__ import annotations

from abc import ABC, abstractmethod
from collections.abc import Callable
from dataclasses import dataclass

from manigraph_shared.errors import ConfigError
from manigraph_shared.messages import Quaternion, Vector3
from manigraph_skills.obstacles import Obstacle


@dataclass(frozen=True)
class Grasp:
    """How to hold an object, chosen by the skill from the scene (``grasp_choice``); a
    driver without fingers to place (the geometric world's magic gripper) ignores it."""

    height: float = 0.0  # TCP above the object's centre, metres (a cover: at its handle)
    turn: float = 0.0  # hand yaw added to the driver's default, radians
    carry_z: float = 0.0  # lowest TCP height for carrying the object across, metres
    #: What the arm must not touch on the way (a driver that plans arm motion checks it).
    obstacles: tuple[Obstacle, ...] = ()


#: A block's grasp at its centre, the driver's default yaw and carry heights.
CENTRE_GRASP = Grasp()


class RobotDriver(ABC):
    """Raises ``SkillError(reason)`` when the robot could not do what was asked."""

    name: str
    #: Takes ``dry_run=True``: plans and validates, moves nothing (``manigraph skills --dry-run``).
    supports_dry_run: bool = False

    @abstractmethod
    def pick(
        self,
        decision_id: str,
        object_id: str,
        position: Vector3,
        orientation: Quaternion,
        grasp: Grasp = CENTRE_GRASP,
    ) -> None:
        """Grasp ``object_id`` whose centre is at ``position`` and lift it clear."""

    @abstractmethod
    def place(
        self,
        decision_id: str,
        object_id: str,
        position: Vector3,
        orientation: Quaternion,
        grasp: Grasp = CENTRE_GRASP,
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
