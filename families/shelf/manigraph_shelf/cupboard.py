"""The cupboard as boxes: its boards, side walls and back wall, each a box in the robot's
frame. Written once for the physics world (which builds them as static SAPIEN boxes) and the
skills (which give them to the arm's collision check as obstacles). A common module of the
package: it imports no service.

The boards span the cupboard's depth (``front_x`` to the back wall) and its inner width; the
side walls stand outside that width and the back wall behind the depth, all from the table up
to the roof's top. The bottom level's floor is the table itself (no board).
"""

from __future__ import annotations

from dataclasses import dataclass

from manigraph_shelf.shelf_geometry import ShelfGeometry

#: The fixture kinds a shelf scene shows its cupboard as (``SceneFixture.kind``): a board a
#: level stands under, and a side or back wall. No action operates them; they are there to
#: be seen (Foxglove, the exports) and avoided.
BOARD = "board"
WALL = "wall"


@dataclass(frozen=True)
class Panel:
    """One box of the cupboard: its name, centre and full size (x, y, z), metres, and its
    kind (:data:`BOARD` or :data:`WALL`)."""

    name: str
    centre: tuple[float, float, float]
    size: tuple[float, float, float]
    kind: str = WALL

    @property
    def low(self) -> tuple[float, float, float]:
        return tuple(c - s / 2 for c, s in zip(self.centre, self.size, strict=True))  # type: ignore[return-value]

    @property
    def high(self) -> tuple[float, float, float]:
        return tuple(c + s / 2 for c, s in zip(self.centre, self.size, strict=True))  # type: ignore[return-value]


def _panel(
    name: str,
    low: tuple[float, float, float],
    high: tuple[float, float, float],
    kind: str = WALL,
) -> Panel:
    centre = tuple((a + b) / 2 for a, b in zip(low, high, strict=True))
    size = tuple(b - a for a, b in zip(low, high, strict=True))
    return Panel(name, centre, size, kind)  # type: ignore[arg-type]


def board_name(level: int) -> str:
    """The board a level stands on (level 0 stands on the table: no board)."""
    return f"shelf:board_{level}"


def cupboard_panels(geometry: ShelfGeometry) -> list[Panel]:
    """The boards over each level (the top one is the roof), the two side walls and the back
    wall of ``geometry``'s cupboard."""
    g = geometry
    x0, x1 = g.front_x, g.back_wall_x
    y0, y1 = g.centre_y - g.width / 2, g.centre_y + g.width / 2
    wall, top = g.wall_thickness, g.roof_top
    panels = [
        _panel(
            board_name(level + 1),
            (x0, y0, g.board_underside(level)),
            (x1, y1, g.board_underside(level) + g.board_thickness),
            BOARD,
        )
        for level in range(g.levels)
    ]
    panels.append(_panel("shelf:side_right", (x0, y0 - wall, 0.0), (x1 + wall, y0, top)))
    panels.append(_panel("shelf:side_left", (x0, y1, 0.0), (x1 + wall, y1 + wall, top)))
    panels.append(_panel("shelf:back", (x1, y0, 0.0), (x1 + wall, y1, top)))
    return panels
