"""The scene graph the structural edits work on: a demonstrated decision's node rows with the
expert's object and goal, the sizes of the world it comes from, and what every edit needs:
where boxes stand, which nodes stand in one column, free table sites, nodes added or removed
with the expert's indices carried along."""

from __future__ import annotations

from dataclasses import dataclass

import torch
from torch import Tensor

from manigraph_planner.gnn.features import FEATURE_SPEC

COVER = FEATURE_SPEC.code("cover")
BLOCK = FEATURE_SPEC.code("block")
BLOCK_GOAL = FEATURE_SPEC.code("block-goal")
COVER_GOAL = FEATURE_SPEC.code("cover-goal")

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
class DemoWorldSizes:
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


def box_sites(x: Tensor, geometry: DemoWorldSizes) -> Tensor:
    """(x, y) of every cover or cover goal above the table: a box stands there."""
    lids = ((x[:, 0] == COVER) | (x[:, 0] == COVER_GOAL)) & (x[:, 3] > geometry.block_size)
    return x[lids, 1:3]


def columns(x: Tensor, rows: Tensor) -> list[Tensor]:
    """Group the node indices ``rows`` by (x, y): one index tensor per column."""
    columns: list[Tensor] = []
    left = rows.tolist()
    while left:
        seed = left[0]
        near = [i for i in left if bool((x[i, 1:3] - x[seed, 1:3]).abs().max() <= COLUMN_TOLERANCE)]
        columns.append(torch.tensor(near))
        left = [i for i in left if i not in near]
    return columns


def away_from_boxes(x: Tensor, column: Tensor, boxes: Tensor, geometry: DemoWorldSizes) -> bool:
    if boxes.numel() == 0:
        return True
    gap = (boxes - x[column[0], 1:3]).abs().amax(dim=1)
    return bool((gap > geometry.box_half_width).all())


def free_site(taken: Tensor, generator: torch.Generator, geometry: DemoWorldSizes) -> Tensor | None:
    low = torch.tensor([geometry.workspace_x[0], geometry.workspace_y[0]])
    high = torch.tensor([geometry.workspace_x[1], geometry.workspace_y[1]])
    for _ in range(50):
        site = low + torch.rand(2, generator=generator) * (high - low)
        if bool(((taken - site).abs().amax(dim=1) >= geometry.site_distance).all()):
            return site
    return None


def rebuild(
    graph: Graph, rows: Tensor, new_objects: list[list[float]], new_goals: list[list[float]]
) -> Graph:
    """``rows`` (edited old nodes) plus new nodes, objects first; indices follow their nodes."""
    k = graph.num_objects
    objects = [rows[:k], torch.tensor(new_objects, dtype=rows.dtype).reshape(-1, 5)]
    goals = [rows[k:], torch.tensor(new_goals, dtype=rows.dtype).reshape(-1, 5)]
    x = torch.cat(objects + goals)
    goal_index = graph.goal_index + len(new_objects)
    return Graph(x, graph.object_index, goal_index)


def remove(graph: Graph, drop: Tensor) -> Graph:
    """``graph`` without the nodes where ``drop`` is true (never the expert's nodes)."""
    keep = ~drop
    index = torch.cumsum(keep.long(), 0) - 1
    return Graph(
        graph.x[keep].clone(), int(index[graph.object_index]), int(index[graph.goal_index])
    )
