"""The shelf as built, filled and approached, written once for its sim (the geometric world
judges slots by it, the physics world builds the cupboard from it), its expert, its skills
and its tests. A common module of the package: it imports no service.

The frame is the robot's: the robot stands at the origin facing +x. The shelf is a cupboard
standing on the table with its open side towards the robot (along -x): a floor (the table
itself, the bottom board at z = 0), one board above each level and a back wall. Each level
has columns of two slots, a BACK slot (deep inside) and a FRONT slot (in front of it). An
object is placed from the front, sliding in under the board above, so a filled front slot
blocks the way to the back slot behind it (:func:`blocked`).

Sizing (:func:`slots_for`): N objects fill N/2 columns, up to :data:`COLUMNS_PER_LEVEL` on a
level, the bottom level first; the cupboard has at least two levels, three when N needs them.
"""

from __future__ import annotations

from dataclasses import dataclass

from manigraph_shared.errors import ConfigError
from manigraph_shared.messages import Scene

#: The rows of a column, as a slot names them: the back slot is filled first.
BACK = "back"
FRONT = "front"
ROWS = (BACK, FRONT)

#: The object: a cube of this edge, metres (category ``block``).
OBJECT_SIZE = 0.04
#: At most this many columns on one level (across y), and at most this many levels.
COLUMNS_PER_LEVEL = 3
MAX_LEVELS = 3
#: The fewest levels a cupboard has.
MIN_LEVELS = 2


@dataclass(frozen=True)
class ShelfGeometry:
    """The cupboard's pose and dimensions, metres, in the robot's frame.

    ``front_x`` is the open side's x, ``depth`` runs from it to the back wall (+x), the
    cupboard is ``width`` wide centred on ``centre_y``. Level ``i`` stands on the board whose
    top is at ``board_tops[i]`` (level 0's is the table); a board is ``board_thickness``
    thick, so the board above level ``i`` has its underside at
    ``board_tops[i] + level_height - board_thickness``. Slots sit at ``back_x`` and
    ``front_x_slot`` (object centres), columns ``column_spacing`` apart across y.
    """

    front_x: float = 0.50
    depth: float = 0.22
    width: float = 0.60
    centre_y: float = 0.0
    level_height: float = 0.17
    board_thickness: float = 0.02
    wall_thickness: float = 0.02
    back_x: float = 0.64
    front_x_slot: float = 0.56
    column_spacing: float = 0.10
    levels: int = MIN_LEVELS

    @property
    def back_wall_x(self) -> float:
        """The inner face of the back wall."""
        return self.front_x + self.depth

    @property
    def board_tops(self) -> tuple[float, ...]:
        """The top of each level's floor board, bottom first (level 0 is the table)."""
        return tuple(level * self.level_height for level in range(self.levels))

    @property
    def roof_top(self) -> float:
        """The top of the board over the highest level (the cupboard's roof)."""
        return self.levels * self.level_height

    def board_underside(self, level: int) -> float:
        """The underside of the board above level ``level`` (the ceiling a place passes
        under)."""
        return (level + 1) * self.level_height - self.board_thickness

    def column_ys(self, columns: int) -> tuple[float, ...]:
        """The y of each of ``columns`` columns on a level, centred on the cupboard."""
        return tuple(
            self.centre_y + (i - (columns - 1) / 2) * self.column_spacing for i in range(columns)
        )


@dataclass(frozen=True)
class Slot:
    """One place on a board: its id (``slot_<level>_<column>_<row>``), its level, column
    and row (:data:`BACK` or :data:`FRONT`), and where the object's centre goes."""

    id: str
    level: int
    column: int
    row: str
    position: tuple[float, float, float]

    @property
    def column_key(self) -> tuple[int, int]:
        """The column this slot belongs to (level, column): its two slots share it."""
        return (self.level, self.column)


def levels_for(objects: int) -> int:
    """How many levels a shelf for ``objects`` objects has; ``ConfigError`` for a count the
    shelf cannot take (odd, below 2 or above its slots)."""
    most = 2 * COLUMNS_PER_LEVEL * MAX_LEVELS
    if objects < 2 or objects % 2 or objects > most:
        raise ConfigError("objects", f"must be even, 2..{most} (got {objects})")
    columns = objects // 2
    return max(MIN_LEVELS, -(-columns // COLUMNS_PER_LEVEL))


def geometry_for(objects: int) -> ShelfGeometry:
    """The cupboard for ``objects`` objects (its levels sized by :func:`levels_for`)."""
    return ShelfGeometry(levels=levels_for(objects))


def slots_for(objects: int, geometry: ShelfGeometry | None = None) -> list[Slot]:
    """The ``objects`` slots of a shelf for that many objects, bottom level first, each
    column's back slot before its front: N/2 columns, up to :data:`COLUMNS_PER_LEVEL` on a
    level, each level's columns centred across y."""
    geometry = geometry or geometry_for(objects)
    columns_left = objects // 2
    if levels_for(objects) > geometry.levels:
        raise ConfigError("objects", f"{objects} objects need more than {geometry.levels} levels")
    slots: list[Slot] = []
    for level, board_top in enumerate(geometry.board_tops):
        columns = min(columns_left, COLUMNS_PER_LEVEL)
        columns_left -= columns
        z = board_top + OBJECT_SIZE / 2
        for column, y in enumerate(geometry.column_ys(columns)):
            for row, x in ((BACK, geometry.back_x), (FRONT, geometry.front_x_slot)):
                slots.append(Slot(f"slot_{level}_{column}_{row}", level, column, row, (x, y, z)))
    return slots


def blocked(slot: Slot, filled: set[str], slots: list[Slot]) -> bool:
    """Whether the way into ``slot`` is blocked: it is a back slot and the front slot of its
    column (one of ``slots``) is among ``filled`` (slot ids). The one place the rule is
    written."""
    if slot.row != BACK:
        return False
    return any(
        other.column_key == slot.column_key and other.row == FRONT and other.id in filled
        for other in slots
    )


#: Where the objects start: a grid of cells on the table in front of the shelf, their centres
#: from ``START_X[0]`` to ``START_X[1]`` and ``START_Y[0]`` to ``START_Y[1]``,
#: ``START_SPACING`` apart (3 x 7 cells, metres); each object takes a cell and lies within
#: ``START_JITTER`` of its centre.
START_X = (0.24, 0.40)
START_Y = (-0.24, 0.24)
START_SPACING = 0.08
START_JITTER = 0.01


def start_cells() -> list[tuple[float, float]]:
    """The (x, y) centres of the start grid's cells, row by row from the robot."""

    def steps(low: float, high: float) -> list[float]:
        return [low + i * START_SPACING for i in range(round((high - low) / START_SPACING) + 1)]

    return [(x, y) for x in steps(*START_X) for y in steps(*START_Y)]


#: The goal attribute that says a slot's row (``back`` or ``front``): what tells a shelf
#: scene (and its back slots) apart, for the sim's Scene, the expert and the planner.
ROW_ATTRIBUTE = "shelf_row"


def is_shelf_scene(scene: Scene) -> bool:
    """Whether ``scene`` (a ``Scene``) is a shelf's: some goal says its row."""
    return any(ROW_ATTRIBUTE in goal.attributes for goal in scene.goals)
