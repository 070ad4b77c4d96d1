r"""Label-preserving structural augmentation: taller towers and distractor boxes.

Twenty box packing/unpacking demonstrations with K = 3, 4 show towers of at most four blocks,
one box and one storage place. Two edits of a demonstrated graph show the network scenes
like the ones it is tested on, and **never change the expert's choice** (each argued below
from the expert's three rules in :mod:`manigraph_planner.policies.expert`, and checked by
``tests/planner/training/test_structure.py`` against the expert itself):

* **Tower extension.** Every free-standing source tower (a column of blocks in no goal, away
  from any box) gets the same number :math:`m` of extra blocks slid in at its bottom, and
  every free-standing goal stack gets :math:`m'` filled goals (each holding a block) slid in
  at its bottom and :math:`f` free goals added on top. Everything above moves up by whole
  block sizes. The highest movable block is still the same block (all source towers rise
  together, so their order is kept), and the lowest free goal is still the same goal (all
  goal stacks rise together; the new goals below are filled, the new goals on top are
  higher). Boxes are left alone: a box holds one layer.
* **Distractors.** A closed box elsewhere on the table (a cover resting on its lid goal,
  both filled; its contents unobserved, as a closed box's are; not while the expert opens a
  box, see :func:`add_distractors`), and a free storage place for covers on the table. The
  expert never moves a cover that is in nothing's way while blocks can be moved or
  uncovered; when closing, it moves the *lowest* cover in a cover goal (a stored cover is
  lower than any cover on a box) to the *highest* free cover goal (a box's lid is higher
  than any storage place). A new storage place ties with the demonstrated one only where
  both are equally right.
* **Idle covers dropped.** When the expert moves a block and every cover rests in a storage
  place on the table (none lies over a box), the covers and all cover goals are removed:
  rule 1 (blocks) never looks at them, and the stacking tasks have none at all.

Nodes are rows ``[category, x, y, z, filled]`` (see :mod:`manigraph_planner.gnn.features`);
objects stay before goals, and the expert's object and goal node indices are carried along.
"""

from __future__ import annotations

from dataclasses import dataclass

import torch
from torch import Tensor

from manigraph_planner.gnn.features import FEATURE_SPEC

COVER = FEATURE_SPEC.code("cover")
BLOCK = FEATURE_SPEC.code("block")
BLOCK_GOAL = FEATURE_SPEC.code("block-goal")
COVER_GOAL = FEATURE_SPEC.code("cover-goal")

#: Cells of a box's block grid, as the tasks fill them: the centre first, then around it.
BOX_CELLS = sorted(
    ((i, j) for i in (-1, 0, 1) for j in (-1, 0, 1)), key=lambda c: (abs(c[0]) + abs(c[1]), c)
)

#: Nodes closer than this in x and y stand in one column.
COLUMN_TOLERANCE = 0.01


@dataclass(frozen=True)
class Graph:
    """A demonstrated decision as node rows plus the expert's object and goal node."""

    x: Tensor  # (N, 5), objects first
    object_index: int
    goal_index: int

    @property
    def num_objects(self) -> int:
        return int((self.x[:, 0] <= BLOCK).sum())


@dataclass(frozen=True)
class SceneGeometry:
    """Sizes of the world the demonstrations come from, metres.

    Args:
        block_size: edge of a block; towers grow in steps of it.
        cover_thickness: a cover's thickness (a stored cover's centre is this / 2 above
            the table).
        grid_pitch: spacing of the block grid on a box's floor.
        box_half_width: half the outer width of a box (cover); no tower is extended this close
            to a box site.
        site_distance: a distractor keeps at least this far (x and y) from every other node.
        workspace_x, workspace_y: where distractors may stand, before the scene is translated.
    """

    block_size: float = 0.04
    cover_thickness: float = 0.01
    grid_pitch: float = 0.045
    box_half_width: float = 0.09
    site_distance: float = 0.2
    workspace_x: tuple[float, float] = (0.3, 0.7)
    workspace_y: tuple[float, float] = (-0.35, 0.35)


def _box_sites(x: Tensor, geometry: SceneGeometry) -> Tensor:
    """(x, y) of every cover or cover goal above the table: a box stands there."""
    lids = ((x[:, 0] == COVER) | (x[:, 0] == COVER_GOAL)) & (x[:, 3] > geometry.block_size)
    return x[lids, 1:3]


def _columns(x: Tensor, rows: Tensor) -> list[Tensor]:
    """Group the node indices ``rows`` by (x, y): one index tensor per column."""
    columns: list[Tensor] = []
    left = rows.tolist()
    while left:
        seed = left[0]
        near = [i for i in left if bool((x[i, 1:3] - x[seed, 1:3]).abs().max() <= COLUMN_TOLERANCE)]
        columns.append(torch.tensor(near))
        left = [i for i in left if i not in near]
    return columns


def _away_from_boxes(x: Tensor, column: Tensor, boxes: Tensor, geometry: SceneGeometry) -> bool:
    if boxes.numel() == 0:
        return True
    gap = (boxes - x[column[0], 1:3]).abs().amax(dim=1)
    return bool((gap > geometry.box_half_width).all())


def _rebuild(
    graph: Graph, rows: Tensor, new_objects: list[list[float]], new_goals: list[list[float]]
) -> Graph:
    """``rows`` (edited old nodes) plus new nodes, objects first; indices follow their nodes."""
    k = graph.num_objects
    objects = [rows[:k], torch.tensor(new_objects, dtype=rows.dtype).reshape(-1, 5)]
    goals = [rows[k:], torch.tensor(new_goals, dtype=rows.dtype).reshape(-1, 5)]
    x = torch.cat(objects + goals)
    goal_index = graph.goal_index + len(new_objects)
    return Graph(x, graph.object_index, goal_index)


def extend_towers(
    graph: Graph, source_levels: int, stack_levels: int, free_levels: int, geometry: SceneGeometry
) -> Graph:
    """Slide ``source_levels`` blocks under every source tower, and ``stack_levels`` filled
    goals (each holding a block) under and ``free_levels`` free goals on top of every goal
    stack.

    Source towers are extended only if every block still to move stands in a free-standing
    column (none in a box), and goal stacks only if every block goal does: otherwise the new
    heights could reorder a tower against a box and change the expert's choice. Returns
    ``graph`` itself where nothing qualifies.
    """
    x = graph.x.clone()
    boxes = _box_sites(x, geometry)
    pitch = geometry.block_size
    rows = torch.nonzero((x[:, 0] == BLOCK) | (x[:, 0] == BLOCK_GOAL)).flatten()
    stacks: list[Tensor] = []
    sources: list[Tensor] = []
    in_box = {"stack": False, "source": False}
    for column in _columns(x, rows):
        codes, filled = x[column, 0], x[column, 4]
        kind = "stack" if bool((codes == BLOCK_GOAL).any()) else "source"
        if kind == "source" and not bool((filled == 0).all()):
            continue  # blocks in goals without their goal visible: leave alone
        if not _away_from_boxes(x, column, boxes, geometry):
            in_box[kind] = True
        else:
            (stacks if kind == "stack" else sources).append(column)
    if in_box["stack"]:
        stacks = []
    if in_box["source"]:
        sources = []
        # Blocks on a box floor stand at one height: beside a tall finished goal stack,
        # "take the lowest block" would explain the expert as well as "the highest" does, and
        # a K-stack's last blocks (low, beside a tall goal stack) would go wrong.
        stack_levels = 0
    new_objects: list[list[float]] = []
    new_goals: list[list[float]] = []
    for column in sources:
        xy = x[column[0], 1:3].tolist()
        bottom = float(x[column, 3].min())
        new_objects += [[BLOCK, *xy, bottom + i * pitch, 0.0] for i in range(source_levels)]
        x[column, 3] += source_levels * pitch
    for column in stacks:
        xy = x[column[0], 1:3].tolist()
        bottom = float(x[column, 3].min())
        top = float(x[column][x[column, 0] == BLOCK_GOAL, 3].max()) + stack_levels * pitch
        for i in range(stack_levels):
            new_goals.append([BLOCK_GOAL, *xy, bottom + i * pitch, 1.0])
            new_objects.append([BLOCK, *xy, bottom + i * pitch, 1.0])
        new_goals += [[BLOCK_GOAL, *xy, top + i * pitch, 0.0] for i in range(1, free_levels + 1)]
        x[column, 3] += stack_levels * pitch
    if not new_objects and not new_goals:
        return graph
    return _rebuild(graph, x, new_objects, new_goals)


def _lid_and_storage_heights(x: Tensor, geometry: SceneGeometry) -> tuple[float, float] | None:
    """Heights of a demonstrated box's lid and storage place (the highest and lowest cover
    goal), or None where the graph shows no box with both."""
    heights = x[x[:, 0] == COVER_GOAL, 3]
    if heights.numel() < 2:
        return None
    lid_z, storage_z = float(heights.max()), float(heights.min())
    if lid_z - storage_z < geometry.block_size:
        return None
    return lid_z, storage_z


def add_distractors(
    graph: Graph,
    closed_box: bool,
    storage: bool,
    generator: torch.Generator,
    geometry: SceneGeometry,
    packed: int = 0,
) -> Graph:
    """Add a closed box (cover on its lid goal) and/or a free storage place, each at a free
    table site. The box holds ``packed`` blocks in their goals (a box packed earlier, seen
    while it was open), else nothing observed. Needs a demonstrated box to copy heights
    from; else returns ``graph``."""
    x = graph.x
    heights = _lid_and_storage_heights(x, geometry)
    if heights is None:
        return graph
    lid_z, storage_z = heights
    if _opened_cover(graph, geometry) is not None:
        # The expert is opening a box. A second closed box would show two covers that differ
        # only in where they stand, which architectures that aggregate over the whole graph
        # (sum or mean) cannot tell apart; no test scene asks for that choice.
        closed_box = False
    new_objects: list[list[float]] = []
    new_goals: list[list[float]] = []
    taken = x[:, 1:3]
    for wanted, node in ((closed_box, "box"), (storage, "storage")):
        if not wanted:
            continue
        site = _free_site(taken, generator, geometry)
        if site is None:
            continue
        taken = torch.cat([taken, site.unsqueeze(0)])
        sx, sy = site.tolist()
        if node == "box":
            new_objects.append([COVER, sx, sy, lid_z, 1.0])
            new_goals.append([COVER_GOAL, sx, sy, lid_z, 1.0])
            for cell in _floor_cells(site, packed, storage_z, geometry):
                new_objects.append([BLOCK, *cell, 1.0])
                new_goals.append([BLOCK_GOAL, *cell, 1.0])
        else:
            new_goals.append([COVER_GOAL, sx, sy, storage_z, 0.0])
    if not new_goals:
        return graph
    return _rebuild(graph, x.clone(), new_objects, new_goals)


def _floor_cells(
    site: Tensor, count: int, storage_z: float, geometry: SceneGeometry
) -> list[list[float]]:
    """Centres ``[x, y, z]`` of the first ``count`` cells of the block grid on the floor of a
    box at ``site`` (the table is a stored cover's half thickness below ``storage_z``)."""
    sx, sy = site.tolist()
    floor = storage_z - geometry.cover_thickness / 2 + geometry.block_size / 2
    pitch = geometry.grid_pitch
    return [[sx + dx * pitch, sy + dy * pitch, floor] for dx, dy in BOX_CELLS[:count]]


def _free_site(taken: Tensor, generator: torch.Generator, geometry: SceneGeometry) -> Tensor | None:
    low = torch.tensor([geometry.workspace_x[0], geometry.workspace_y[0]])
    high = torch.tensor([geometry.workspace_x[1], geometry.workspace_y[1]])
    for _ in range(50):
        site = low + torch.rand(2, generator=generator) * (high - low)
        if bool(((taken - site).abs().amax(dim=1) >= geometry.site_distance).all()):
            return site
    return None


def drop_idle_covers(graph: Graph, geometry: SceneGeometry) -> Graph:
    """Remove every cover and cover goal when the expert's object is a block and every cover
    lies on the table (none on a box). Returns ``graph`` itself otherwise."""
    x = graph.x
    if int(x[graph.object_index, 0]) != BLOCK:
        return graph
    covers = x[:, 0] == COVER
    if not bool(covers.any()) or bool((x[covers, 3] > geometry.block_size).any()):
        return graph
    return _remove(graph, covers | (x[:, 0] == COVER_GOAL))


def _remove(graph: Graph, drop: Tensor) -> Graph:
    """``graph`` without the nodes where ``drop`` is true (never the expert's nodes)."""
    keep = ~drop
    index = torch.cumsum(keep.long(), 0) - 1
    return Graph(
        graph.x[keep].clone(), int(index[graph.object_index]), int(index[graph.goal_index])
    )


def _opened_cover(graph: Graph, geometry: SceneGeometry) -> Tensor | None:
    """The expert's cover row when it is taking a cover off a box, else None."""
    chosen = graph.x[graph.object_index]
    if int(chosen[0]) == COVER and float(chosen[3]) > geometry.block_size:
        return chosen
    return None


def _under(cover: Tensor, x: Tensor, geometry: SceneGeometry) -> Tensor:
    """Which nodes lie inside the box that ``cover`` (a node row) closes."""
    beside = (x[:, 1:3] - cover[1:3]).abs().amax(dim=1) <= geometry.box_half_width
    return beside & (x[:, 3] < cover[3])


def hide_box_contents(graph: Graph, geometry: SceneGeometry) -> Graph:
    """When the expert takes a cover off a box, remove the blocks and block goals inside that
    box: the scene as a robot sees it when what a closed box holds is not observed (box
    rearrangement). The box still has to be opened for the task to go on, so the label is
    the expert's choice on the full scene. Returns ``graph`` itself otherwise."""
    cover = _opened_cover(graph, geometry)
    if cover is None:
        return graph
    x = graph.x
    drop = _under(cover, x, geometry) & ((x[:, 0] == BLOCK) | (x[:, 0] == BLOCK_GOAL))
    if not bool(drop.any()):
        return graph
    return _remove(graph, drop)


def add_open_box(
    graph: Graph,
    generator: torch.Generator,
    geometry: SceneGeometry,
    loose_blocks: int = 0,
    free_goals: int = 0,
) -> Graph:
    """Add an open box elsewhere: a free lid goal, its cover in a storage place, and on its
    floor ``loose_blocks`` blocks in no goal or ``free_goals`` free block goals (see
    :func:`open_box_contents` for when either keeps the label).

    An empty one: the expert ignores it when moving or uncovering blocks (the new lid is
    higher than any storage place, so it is never the lowest free cover goal); when closing,
    the new stored cover and lid tie with the demonstrated ones, and either pairing closes a
    box. Needs a demonstrated box to copy heights from; else returns ``graph``."""
    x = graph.x
    heights = _lid_and_storage_heights(x, geometry)
    if heights is None:
        return graph
    lid_z, storage_z = heights
    box = _free_site(x[:, 1:3], generator, geometry)
    if box is None:
        return graph
    store = _free_site(torch.cat([x[:, 1:3], box.unsqueeze(0)]), generator, geometry)
    if store is None:
        return graph
    (bx, by), (sx, sy) = box.tolist(), store.tolist()
    objects = [[COVER, sx, sy, storage_z, 1.0]]
    goals = [[COVER_GOAL, bx, by, lid_z, 0.0], [COVER_GOAL, sx, sy, storage_z, 1.0]]
    objects += [
        [BLOCK, *cell, 0.0] for cell in _floor_cells(box, loose_blocks, storage_z, geometry)
    ]
    goals += [
        [BLOCK_GOAL, *cell, 0.0] for cell in _floor_cells(box, free_goals, storage_z, geometry)
    ]
    return _rebuild(graph, x.clone(), objects, goals)


def open_box_contents(graph: Graph, geometry: SceneGeometry) -> tuple[str, ...]:
    """What an open box added while the expert takes a cover off a box may hold and keep
    the label: ``"blocks"`` (loose blocks on its floor) where no free block goal lies outside
    the box being opened, ``"goals"`` (free block goals on its floor) where no block still
    to move lies outside it; nothing where the expert is not opening a box.

    Rule 1 moves a block only when a movable block and an uncovered free goal both exist;
    the box being opened hides (covers) everything inside it, so with only one of the two
    outside it, rule 1 still has nothing to do and rule 2 opens the same box: the new
    blocks or goals lie under no cover. This is box rearrangement's second step: one box
    open, its blocks (or its free goals) in view, the other box still closed."""
    cover = _opened_cover(graph, geometry)
    if cover is None:
        return ()
    x = graph.x
    outside_free = ~_under(cover, x, geometry) & (x[:, 4] == 0.0)
    kinds = []
    if not bool((outside_free & (x[:, 0] == BLOCK_GOAL)).any()):
        kinds.append("blocks")
    if not bool((outside_free & (x[:, 0] == BLOCK)).any()):
        kinds.append("goals")
    return tuple(kinds)


def is_closing(graph: Graph, geometry: SceneGeometry) -> bool:
    """The expert puts a cover from the table back onto a box."""
    chosen = graph.x[graph.object_index]
    return int(chosen[0]) == COVER and float(chosen[3]) <= geometry.block_size


def add_finished_tower(
    graph: Graph,
    levels: int,
    generator: torch.Generator,
    geometry: SceneGeometry,
    free_levels: int = 0,
) -> Graph:
    """Add a goal stack elsewhere: ``levels`` filled block goals, each holding its block, and
    ``free_levels`` free goals on top, where the expert moves a block to a goal on a box
    floor.

    Rule 1 never moves a block that is in a goal nor fills a filled goal, and the new free
    goals stand higher than any goal on a box floor, so the label stays.
    In the demonstrations a tall filled goal stack comes only with box unpacking, where every
    block still to move lies on the box floor; without this edit "the lowest block" explains
    those decisions as well as "the highest", and a K-stack's last blocks go wrong."""
    x = graph.x
    if levels < 1 or int(x[graph.object_index, 0]) != BLOCK:
        return graph
    floor = geometry.block_size / 2 + COLUMN_TOLERANCE
    if free_levels and float(x[graph.goal_index, 3]) > floor:
        free_levels = 0  # the expert's goal is not on a floor: new free goals could be lower
    site = _free_site(x[:, 1:3], generator, geometry)
    if site is None:
        return graph
    sx, sy = site.tolist()
    z = [geometry.block_size * (i + 0.5) for i in range(levels + free_levels)]
    blocks = [[BLOCK, sx, sy, h, 1.0] for h in z[:levels]]
    goals = [[BLOCK_GOAL, sx, sy, h, float(i < levels)] for i, h in enumerate(z)]
    return _rebuild(graph, x.clone(), blocks, goals)


def drop_finished_pairs(graph: Graph, levels: int, geometry: SceneGeometry) -> Graph:
    """Remove finished work: up to ``levels`` filled block goals with the blocks in them from
    the bottom of every free-standing goal stack (what stood above them moves down by whole
    block sizes), and every filled block goal with its block on a box floor.

    The inverse of :func:`extend_towers` for goal stacks, and the way to small graphs: a
    K-stack with K = 2 has four nodes, fewer than any demonstration (K = 3, 4) shows. Rule 1
    never moves a block in a goal nor fills a filled goal; every goal stack moves down by the
    same number of levels, so the lowest free goal is still the same goal, and a box floor's
    goals move not at all. Goal stacks are left alone where some block goal lies in a box
    (stacks moving down could then pass below the box floor's free goals). Returns ``graph``
    itself where nothing qualifies."""
    x = graph.x
    boxes = _box_sites(x, geometry)
    pitch = geometry.block_size
    goal_rows = torch.nonzero(x[:, 0] == BLOCK_GOAL).flatten()
    stacks: list[Tensor] = []
    drop = torch.zeros(x.shape[0], dtype=torch.bool)
    any_in_box = False
    for column in _columns(x, goal_rows):
        if _away_from_boxes(x, column, boxes, geometry):
            stacks.append(column)
            continue
        any_in_box = True
        for g in column.tolist():
            if float(x[g, 4]) == 1.0:
                drop |= _block_in(x, g)
                drop[g] = True
    if not any_in_box and stacks:
        levels = min([levels] + [_filled_at_bottom(x, column) for column in stacks])
        x = x.clone()
        for column in stacks:
            order = column[torch.argsort(x[column, 3])]
            for g in order[:levels].tolist():
                drop |= _block_in(x, g)
                drop[g] = True
            if levels:
                cut = float(x[order[levels - 1], 3]) + pitch / 2
                xy = x[order[0], 1:3]
                above = ((x[:, 1:3] - xy).abs().amax(dim=1) <= COLUMN_TOLERANCE) & (x[:, 3] > cut)
                above &= (x[:, 0] == BLOCK) | (x[:, 0] == BLOCK_GOAL)
                x[above, 3] -= levels * pitch
    if not bool(drop.any()) or bool(drop[graph.object_index] | drop[graph.goal_index]):
        return graph
    return _remove(Graph(x, graph.object_index, graph.goal_index), drop)


def _filled_at_bottom(x: Tensor, column: Tensor) -> int:
    """How many of ``column``'s block goals, from the bottom up, are filled."""
    filled = x[column[torch.argsort(x[column, 3])], 4].tolist()
    count = 0
    while count < len(filled) and filled[count] == 1.0:
        count += 1
    return count


def _block_in(x: Tensor, goal: int) -> Tensor:
    """The filled blocks standing in block goal ``goal`` (same place within tolerance)."""
    near = (x[:, 1:4] - x[goal, 1:4]).abs().amax(dim=1) <= COLUMN_TOLERANCE
    return near & (x[:, 0] == BLOCK) & (x[:, 4] == 1.0)
