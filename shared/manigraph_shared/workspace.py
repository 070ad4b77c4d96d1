"""The box the robot may reach into: skills refuse targets outside it before any motion, and
the sim refuses robot commands outside it (defence in depth: a forged command is refused even
if it never went through skills)."""

from __future__ import annotations

from dataclasses import dataclass

from manigraph_shared.errors import ConfigError
from manigraph_shared.messages import Vector3


@dataclass(frozen=True)
class Workspace:
    """Axis-aligned bounds in the robot frame, metres. The default is generous for a Panda
    at the table edge; the geometric world also stacks 40 blocks, hence the height."""

    x: tuple[float, float] = (0.1, 0.9)
    y: tuple[float, float] = (-0.6, 0.6)
    z: tuple[float, float] = (-0.01, 2.0)

    def __post_init__(self) -> None:
        for axis in ("x", "y", "z"):
            low, high = getattr(self, axis)
            if not low < high:
                raise ConfigError(f"workspace.{axis}", f"lower bound {low} must be < upper {high}")

    def contains(self, point: Vector3) -> bool:
        return all(
            low <= value <= high
            for value, (low, high) in zip(point.as_tuple(), (self.x, self.y, self.z), strict=True)
        )

    @classmethod
    def parse(cls, text: str) -> Workspace:
        """``xmin,xmax,ymin,ymax,zmin,zmax`` in metres."""
        try:
            values = [float(v) for v in text.split(",")]
        except ValueError:
            raise ConfigError("workspace", f"'{text}' is not six numbers") from None
        if len(values) != 6:
            raise ConfigError("workspace", f"expected xmin,xmax,ymin,ymax,zmin,zmax, got '{text}'")
        return cls((values[0], values[1]), (values[2], values[3]), (values[4], values[5]))
