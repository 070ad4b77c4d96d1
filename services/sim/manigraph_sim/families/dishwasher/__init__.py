"""The dishwasher task's world: two sliding racks with plate and bowl slots, dishes on a
counter, the paper's loading rules (docs/dishwasher.md).

The task in one place: its model and geometric world (:mod:`.model`,
:mod:`.dishwasher_world`), its registered task with layout sampler and success check
(:mod:`.task`, registered by ``tasks/__init__.py``), its Scene (:mod:`.scene`) and its SAPIEN
cabinet and dishes (:mod:`.physics`, imported only by the physics backend)."""
