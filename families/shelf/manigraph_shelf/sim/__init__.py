"""The shelf family (:class:`~manigraph_shelf.sim.family.ShelfFamily`): blocks from the table
onto the boards of a shelf, laid out as every family is: its unit (:mod:`.family`), options
(:mod:`.options`), task (:mod:`.task`), geometric world (:mod:`.shelf_world`) and Scene
(:mod:`.scene`)."""
