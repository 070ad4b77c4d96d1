"""The dishwasher family (:class:`~manigraph_dishwasher.sim.family.DishwasherFamily`):
two sliding racks with plate and bowl slots, dishes on a counter, the paper's loading rules
(docs/dishwasher.md), laid out as every family is: its unit (:mod:`.family`), options
(:mod:`.options`), model (:mod:`.model`), task (:mod:`.task`), geometric world
(:mod:`.dishwasher_world`), Scene (:mod:`.scene`) and SAPIEN cabinet and dishes
(:mod:`.physics`, imported only by the physics backend)."""
