r"""Label-preserving structural augmentation: taller towers and distractor boxes.

Twenty box packing/unpacking demonstrations with K = 3, 4 show towers of at most four blocks,
one box and one storage place. Two edits of a demonstrated graph show the network scenes
like the ones it is tested on, and **never change the expert's choice** (each argued below
from the expert's three rules in :mod:`manigraph_blocks.planner.expert`, and checked by
``tests/training/test_structure.py`` against the expert itself):

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
The graph and its sizes are in :mod:`.graph`, the tower edits in :mod:`.towers`, the box and
cover edits in :mod:`.boxes`.
"""

from manigraph_blocks.training.structure.boxes import (
    BOX_CELLS,
    add_distractors,
    add_open_box,
    drop_idle_covers,
    hide_box_contents,
    is_closing,
    open_box_contents,
)
from manigraph_blocks.training.structure.graph import (
    BLOCK,
    BLOCK_GOAL,
    COLUMN_TOLERANCE,
    COVER,
    COVER_GOAL,
    DemoWorldSizes,
    Graph,
)
from manigraph_blocks.training.structure.towers import (
    add_finished_tower,
    drop_finished_pairs,
    extend_towers,
)

__all__ = [
    "BLOCK",
    "BLOCK_GOAL",
    "BOX_CELLS",
    "COLUMN_TOLERANCE",
    "COVER",
    "COVER_GOAL",
    "DemoWorldSizes",
    "Graph",
    "add_distractors",
    "add_finished_tower",
    "add_open_box",
    "drop_finished_pairs",
    "drop_idle_covers",
    "extend_towers",
    "hide_box_contents",
    "is_closing",
    "open_box_contents",
]
