"""The block family: blocks, covers and boxes (the paper's stacking, pyramid and box
rearrangement) and every user's task file, as one package (docs/families.md).

Its parts: ``sim`` (its tasks, worlds and success check), ``planner`` (its expert and the
augmentation recipes the generic trainer draws with), ``skills`` (its boxes' walls as
obstacles). Each service finds its part through :data:`PARTS`, which this package's
``manigraph.families`` entry point names; it is the fallback family of the planner and the
skills (a scene no other family claims is a block scene).
"""

#: Where each service finds this family's part (``"module:attribute"``), imported only when
#: that service first reads its family registry.
PARTS = {
    "sim": "manigraph_blocks.sim.family:BlocksFamily",
    "planner": "manigraph_blocks.planner:FAMILY",
    "skills": "manigraph_blocks.skills:FAMILY",
}
