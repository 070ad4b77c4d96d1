"""The robot drivers, registered by name with their options.

Imports no driver (the Panda's needs Pinocchio): ``manigraph skills --help`` lists every
driver's flags from the options here; a driver's module is imported when it is created.
Register a new driver with its options dataclass::

    DRIVERS.add_lazy("ur5", "my_package.ur5:Ur5Driver", options=Ur5Options, help="...")

and give ``Ur5Driver`` a ``from_options(bus, options)`` (:class:`~.base.RobotDriver`).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

from manigraph_shared.options import Interval, Options, option
from manigraph_shared.registry import Registry

if TYPE_CHECKING:
    from manigraph_skills.drivers.base import RobotDriver

__all__ = [
    "DRIVERS",
    "BusGripperOptions",
    "FrankaOptions",
    "MotionOptions",
    "PandaSimOptions",
    "create_driver",
]

POSITIVE = Interval(0, None, low_open=True)


@dataclass(frozen=True)
class BusGripperOptions(Options):
    timeout: float = option(
        10.0, help="wait this long for the sim's answer", within=POSITIVE, unit="s"
    )


@dataclass(frozen=True)
class MotionOptions(Options):
    """The checks of a Panda that plans its own motion (``PandaMotionDriver``)."""

    min_grasp_width: float = option(
        0.005,
        help="fingers closed to less than this hold nothing (grasp_slipped)",
        within=Interval(0, 0.08, high_open=True),
        unit="m",
    )
    placement_tolerance: float = option(
        0.02,
        help="an object released farther than this from its goal missed it (placement_missed)",
        within=POSITIVE,
        unit="m",
    )


@dataclass(frozen=True)
class PandaSimOptions(MotionOptions):
    timeout: float = option(
        60.0, help="wait this long for the sim's answer", within=POSITIVE, unit="s"
    )


@dataclass(frozen=True)
class FrankaOptions(Options):
    """The rest (address, speed, limits) comes from ``MANIGRAPH_FRANKA_*`` (``FrankaConfig``)."""

    dry_run: bool = option(
        False, help="plan, validate and log every trajectory; move nothing (a first check)"
    )


DRIVERS: Registry[type[RobotDriver]] = Registry("driver")
DRIVERS.add_lazy(
    "sim-gripper",
    "manigraph_skills.drivers.bus_gripper:BusGripperDriver",
    options=BusGripperOptions,
    help="the geometric sim's magic gripper (Cartesian commands)",
)
DRIVERS.add_lazy(
    "panda-sim",
    "manigraph_skills.drivers.panda_sim:PandaSimDriver",
    options=PandaSimOptions,
    help="the physics sim's Panda (joint trajectories planned here)",
)
DRIVERS.add_lazy(
    "franka",
    "manigraph_skills.drivers.franka:FrankaDriver",
    options=FrankaOptions,
    help="the real Franka Panda through franky (MANIGRAPH_FRANKA_ADDRESS; docs/franka.md)",
)


def create_driver(name: str, bus: Any, **values: Any) -> RobotDriver:
    """Driver ``name`` on ``bus`` with ``values`` as its options (``ConfigError`` naming a bad
    one)."""
    options = DRIVERS.options(name, values)
    return DRIVERS[name].from_options(bus, options)
