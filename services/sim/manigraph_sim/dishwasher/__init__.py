"""The dishwasher task's world: two sliding racks with plate and bowl slots, dishes on a
counter, the paper's loading rules (docs/dishwasher.md)."""
