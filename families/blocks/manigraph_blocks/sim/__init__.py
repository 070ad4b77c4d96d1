"""The block family (:class:`~manigraph_blocks.sim.family.BlocksFamily`): blocks
and covers on a table, boxes, and user task files, laid out as every family is: its unit
(:mod:`.family`), options (:mod:`.options`), tasks (:mod:`.stack`, :mod:`.pyramid`,
:mod:`.boxes`, :mod:`.task_file` and its helpers), geometric world (:mod:`.geometric_world`),
Scene (:mod:`.scene`) and physics reading (:mod:`.physics`, :mod:`.physics_boxes`)."""
