"""The Franka driver's configuration: one frozen dataclass, validated once at start-up.

Every field maps onto an environment variable ``MANIGRAPH_FRANKA_<FIELD>`` (upper case), so
the compose ``hardware`` profile configures the driver without a file; ``--dry-run`` on
``manigraph skills`` sets ``dry_run``. A bad value stops start-up with a ``ConfigError``
naming the field (``franka.speed_factor``) and the allowed range.
"""

from __future__ import annotations

import dataclasses
import ipaddress
import re
from collections.abc import Mapping
from dataclasses import dataclass, field

from manigraph_shared.errors import ConfigError
from manigraph_shared.workspace import Workspace

ENV_PREFIX = "MANIGRAPH_FRANKA_"

#: A hostname (RFC 1123 labels) when the address is not an IP literal.
_HOSTNAME = re.compile(r"^(?=.{1,253}$)([A-Za-z0-9]([A-Za-z0-9-]{0,61}[A-Za-z0-9])?\.?)+$")

#: Where the TCP may go on a Panda at a table edge (robot base frame, metres): in front of
#: the base, within its reach, and never lower than 1 cm above the table top (z = 0), where
#: the fingertips (9.5 mm below the TCP) would touch it.
FRANKA_WORKSPACE = Workspace(x=(0.15, 0.85), y=(-0.6, 0.6), z=(0.01, 0.8))


@dataclass(frozen=True)
class FrankaConfig:
    """How to reach and drive one Franka Panda (FCI) with its hand."""

    #: The robot's FCI hostname or IP address; may be empty only for a dry run (plans
    #: then start from the home pose instead of the robot's joints).
    address: str = ""
    #: A Franka Hand is mounted; without one, a trajectory that closes the gripper is refused.
    gripper: bool = True
    #: Scales the planned timing on the robot (0.1: ten times slower than planned) and
    #: franky's velocity, acceleration and jerk limits. (0, 1].
    speed_factor: float = 0.1
    #: Grasping force of the hand, N. The Franka Hand holds 70 N continuously.
    grasp_force: float = 20.0
    #: Finger speed, m/s (the Franka Hand: at most 0.2).
    gripper_speed: float = 0.1
    #: Expected width of a grasped object, m; the grasp accepts anything from 0 to twice it.
    grasp_width: float = 0.04
    #: libfranka's reflex thresholds: the robot stops when a contact force at the end
    #: effector exceeds ``contact_force`` N or a joint torque ``contact_torque`` N m.
    contact_force: float = 30.0
    contact_torque: float = 20.0
    #: The box the TCP must stay in at every trajectory point (robot base frame).
    workspace: Workspace = field(default_factory=lambda: FRANKA_WORKSPACE)
    #: Kept from each joint's position limit, radians.
    joint_margin: float = 0.02
    #: Fraction of the Panda's joint velocity and acceleration limits a planned trajectory
    #: may use (before ``speed_factor`` slows it further). (0, 1].
    limit_fraction: float = 1.0
    #: Largest joint difference between the robot and a trajectory's first point, radians.
    start_tolerance: float = 0.02
    #: Seconds to wait for the robot to answer before giving up (the library alone waits
    #: 60 s on an address where nothing answers).
    connect_timeout: float = 5.0
    #: libfranka's realtime check: on a kernel without PREEMPT_RT the library refuses to
    #: connect unless this is off (off is for dry runs and tests, never for motion).
    realtime: bool = True
    #: Plan, validate and log every trajectory; move nothing.
    dry_run: bool = False

    def __post_init__(self) -> None:
        if not self.dry_run and not self.address:
            raise ConfigError(
                "franka.address",
                f"the robot's FCI address is required (set {ENV_PREFIX}ADDRESS), or use --dry-run",
            )
        if self.address and not _valid_address(self.address):
            raise ConfigError("franka.address", f"'{self.address}' is not a hostname or IP")
        _in_range("speed_factor", self.speed_factor, 0.0, 1.0, "")
        _in_range("grasp_force", self.grasp_force, 0.0, 70.0, " N")
        _in_range("gripper_speed", self.gripper_speed, 0.0, 0.2, " m/s")
        _in_range("grasp_width", self.grasp_width, 0.0, 0.08, " m")
        _in_range("contact_force", self.contact_force, 0.0, 100.0, " N")
        _in_range("contact_torque", self.contact_torque, 0.0, 87.0, " N m")
        _in_range("limit_fraction", self.limit_fraction, 0.0, 1.0, "")
        _in_range("connect_timeout", self.connect_timeout, 0.0, 60.0, " s")
        if not 0.0 <= self.joint_margin <= 0.2:
            raise ConfigError(
                "franka.joint_margin", f"must be in [0, 0.2] rad, got {self.joint_margin}"
            )
        if not 0.0 < self.start_tolerance <= 0.2:
            raise ConfigError(
                "franka.start_tolerance", f"must be in (0, 0.2] rad, got {self.start_tolerance}"
            )

    @classmethod
    def from_env(cls, environ: Mapping[str, str], **overrides: object) -> FrankaConfig:
        """The config from ``MANIGRAPH_FRANKA_*`` variables, then ``overrides`` over them."""
        values: dict[str, object] = {}
        for item in dataclasses.fields(cls):
            name = ENV_PREFIX + item.name.upper()
            if name not in environ:
                continue
            text = environ[name].strip()
            values[item.name] = _parse(item.name, name, text)
        values.update(overrides)
        return cls(**values)  # type: ignore[arg-type]


def _parse(field_name: str, variable: str, text: str) -> object:
    kind = {f.name: f.type for f in dataclasses.fields(FrankaConfig)}[field_name]
    if field_name == "address":
        return text
    if field_name == "workspace":
        try:
            return Workspace.parse(text)
        except ConfigError as exc:
            raise ConfigError(f"franka.workspace ({variable})", exc.problem) from None
    if kind == "bool":
        if text.lower() in ("1", "true", "yes", "on"):
            return True
        if text.lower() in ("0", "false", "no", "off", ""):
            return False
        raise ConfigError(f"franka.{field_name} ({variable})", f"'{text}' is not a boolean")
    try:
        return float(text)
    except ValueError:
        raise ConfigError(
            f"franka.{field_name} ({variable})", f"'{text}' is not a number"
        ) from None


def _in_range(name: str, value: float, low: float, high: float, unit: str) -> None:
    if not low < value <= high:
        raise ConfigError(f"franka.{name}", f"must be in ({low:g}, {high:g}]{unit}, got {value}")


def _valid_address(address: str) -> bool:
    try:
        ipaddress.ip_address(address)
        return True
    except ValueError:
        return bool(_HOSTNAME.match(address))
