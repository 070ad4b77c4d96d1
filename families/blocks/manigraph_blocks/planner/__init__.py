"""The block family's planner: the paper's tasks (stack, pyramid, boxes) and every task file.

Its expert (:mod:`.expert`, ``expert``: the paper's three rules, or the generic matching
rules where goals say what they accept), its training recipe per architecture
in its training part (``manigraph_blocks.training``: ``recipes``, with ``augment``,
``structure``). Its policies have the paper's ``object-goal`` heads over the paper's
five node features or a task file's (``gnn.task_features``), built, loaded and trained by
the generic layers, so it names none of those parts. It is the fallback family: a scene
no other family claims is a block scene.
"""

from manigraph_blocks.planner import expert  # noqa: F401  (registers its expert)
from manigraph_planner.family import PlannerFamily

#: This family's planner part (its package's ``manigraph.families`` entry names it).
FAMILY = PlannerFamily(
    name="blocks",
    heads="object-goal",
    experts=("expert",),
    fallback=True,
    recipe="manigraph_blocks.training.recipes:RECIPES",
    help="blocks, covers and boxes, and any task file: object and goal heads",
)
