"""Structural edits of towers and goal stacks: taller towers (:func:`extend_towers`), a
finished goal stack elsewhere (:func:`add_finished_tower`), finished work removed
(:func:`drop_finished_pairs`). Why each keeps the expert's choice: :mod:`..structure`."""

from __future__ import annotations

import torch
from torch import Tensor

from manigraph_blocks.training.structure.graph import (
    BLOCK,
    BLOCK_GOAL,
    COLUMN_TOLERANCE,
    DemoWorldSizes,
    Graph,
    away_from_boxes,
    box_sites,
    columns,
    free_site,
    rebuild,
    remove,
)


def extend_towers(
    graph: Graph, source_levels: int, stack_levels: int, free_levels: int, geometry: DemoWorldSizes
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
    boxes = box_sites(x, geometry)
    pitch = geometry.block_size
    rows = torch.nonzero((x[:, 0] == BLOCK) | (x[:, 0] == BLOCK_GOAL)).flatten()
    stacks: list[Tensor] = []
    sources: list[Tensor] = []
    in_box = {"stack": False, "source": False}
    for column in columns(x, rows):
        codes, filled = x[column, 0], x[column, 4]
        kind = "stack" if bool((codes == BLOCK_GOAL).any()) else "source"
        if kind == "source" and not bool((filled == 0).all()):
            continue  # blocks in goals without their goal visible: leave alone
        if not away_from_boxes(x, column, boxes, geometry):
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
    return rebuild(graph, x, new_objects, new_goals)


def add_finished_tower(
    graph: Graph,
    levels: int,
    generator: torch.Generator,
    geometry: DemoWorldSizes,
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
    site = free_site(x[:, 1:3], generator, geometry)
    if site is None:
        return graph
    sx, sy = site.tolist()
    z = [geometry.block_size * (i + 0.5) for i in range(levels + free_levels)]
    blocks = [[BLOCK, sx, sy, h, 1.0] for h in z[:levels]]
    goals = [[BLOCK_GOAL, sx, sy, h, float(i < levels)] for i, h in enumerate(z)]
    return rebuild(graph, x.clone(), blocks, goals)


def drop_finished_pairs(graph: Graph, levels: int, geometry: DemoWorldSizes) -> Graph:
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
    boxes = box_sites(x, geometry)
    pitch = geometry.block_size
    goal_rows = torch.nonzero(x[:, 0] == BLOCK_GOAL).flatten()
    stacks: list[Tensor] = []
    drop = torch.zeros(x.shape[0], dtype=torch.bool)
    any_in_box = False
    for column in columns(x, goal_rows):
        if away_from_boxes(x, column, boxes, geometry):
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
    return remove(Graph(x, graph.object_index, graph.goal_index), drop)


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
