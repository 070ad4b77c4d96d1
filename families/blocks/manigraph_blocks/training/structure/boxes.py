"""Structural edits of boxes and covers: distractor boxes and storage places
(:func:`add_distractors`, :func:`add_open_box`), idle covers dropped
(:func:`drop_idle_covers`), a box's unobserved contents hidden (:func:`hide_box_contents`).
Why each keeps the expert's choice: :mod:`..structure`."""

from __future__ import annotations

import torch
from torch import Tensor

from manigraph_blocks.training.structure.graph import (
    BLOCK,
    BLOCK_GOAL,
    COVER,
    COVER_GOAL,
    DemoWorldSizes,
    Graph,
    free_site,
    rebuild,
    remove,
)

#: Cells of a box's block grid, as the tasks fill them: the centre first, then around it.
BOX_CELLS = sorted(
    ((i, j) for i in (-1, 0, 1) for j in (-1, 0, 1)), key=lambda c: (abs(c[0]) + abs(c[1]), c)
)


def _lid_and_storage_heights(x: Tensor, geometry: DemoWorldSizes) -> tuple[float, float] | None:
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
    geometry: DemoWorldSizes,
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
        site = free_site(taken, generator, geometry)
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
    return rebuild(graph, x.clone(), new_objects, new_goals)


def _floor_cells(
    site: Tensor, count: int, storage_z: float, geometry: DemoWorldSizes
) -> list[list[float]]:
    """Centres ``[x, y, z]`` of the first ``count`` cells of the block grid on the floor of a
    box at ``site`` (the table is a stored cover's half thickness below ``storage_z``)."""
    sx, sy = site.tolist()
    floor = storage_z - geometry.cover_thickness / 2 + geometry.block_size / 2
    pitch = geometry.grid_pitch
    return [[sx + dx * pitch, sy + dy * pitch, floor] for dx, dy in BOX_CELLS[:count]]


def drop_idle_covers(graph: Graph, geometry: DemoWorldSizes) -> Graph:
    """Remove every cover and cover goal when the expert's object is a block and every cover
    lies on the table (none on a box). Returns ``graph`` itself otherwise."""
    x = graph.x
    if int(x[graph.object_index, 0]) != BLOCK:
        return graph
    covers = x[:, 0] == COVER
    if not bool(covers.any()) or bool((x[covers, 3] > geometry.block_size).any()):
        return graph
    return remove(graph, covers | (x[:, 0] == COVER_GOAL))


def _opened_cover(graph: Graph, geometry: DemoWorldSizes) -> Tensor | None:
    """The expert's cover row when it is taking a cover off a box, else None."""
    chosen = graph.x[graph.object_index]
    if int(chosen[0]) == COVER and float(chosen[3]) > geometry.block_size:
        return chosen
    return None


def _under(cover: Tensor, x: Tensor, geometry: DemoWorldSizes) -> Tensor:
    """Which nodes lie inside the box that ``cover`` (a node row) closes."""
    beside = (x[:, 1:3] - cover[1:3]).abs().amax(dim=1) <= geometry.box_half_width
    return beside & (x[:, 3] < cover[3])


def hide_box_contents(graph: Graph, geometry: DemoWorldSizes) -> Graph:
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
    return remove(graph, drop)


def add_open_box(
    graph: Graph,
    generator: torch.Generator,
    geometry: DemoWorldSizes,
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
    box = free_site(x[:, 1:3], generator, geometry)
    if box is None:
        return graph
    store = free_site(torch.cat([x[:, 1:3], box.unsqueeze(0)]), generator, geometry)
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
    return rebuild(graph, x.clone(), objects, goals)


def open_box_contents(graph: Graph, geometry: DemoWorldSizes) -> tuple[str, ...]:
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


def is_closing(graph: Graph, geometry: DemoWorldSizes) -> bool:
    """The expert puts a cover from the table back onto a box."""
    chosen = graph.x[graph.object_index]
    return int(chosen[0]) == COVER and float(chosen[3]) <= geometry.block_size
