"""The shelf family: blocks from the table onto the boards of a shelf, each placed from the
front under the board above, as one package (docs/families.md).

A board's slots come in columns of two, a back slot behind a front slot; a filled front slot
blocks the way to the back one, so the order matters (:mod:`.shelf_geometry`). Each service
finds its part through :data:`PARTS`, which this package's ``manigraph.families`` entry
point names.
"""

#: Where each service finds this family's part (``"module:attribute"``), imported only when
#: that service first reads its family registry.
PARTS = {
    "sim": "manigraph_shelf.sim.family:ShelfFamily",
    "planner": "manigraph_shelf.planner:FAMILY",
    "skills": "manigraph_shelf.skills:FAMILY",
    "tools": "manigraph_shelf.tools:FAMILY",
}
