"""Dishwasher loading (paper, section 'Dishwasher loading experiments')."""

from __future__ import annotations

import numpy as np

from manigraph_dishwasher.sim.dishwasher_world import resting_height
from manigraph_dishwasher.sim.model import (
    BOTTOM,
    BOWL,
    MAX_DISHES,
    PLATE,
    SLOT_PITCH,
    SLOTS_PER_ROW,
    TOP,
    Dish,
    DishwasherLayout,
    Preference,
    Rack,
    Slot,
)
from manigraph_dishwasher.sim.options import DishwasherTask
from manigraph_shared.errors import TaskError
from manigraph_sim.tasks.base import register_task
from manigraph_sim.world_model import Body, Goal

#: Where the dishes start: a counter in front of the robot, a grid of 10 cm cells (metres);
#: each dish takes a random cell and lies within 1 cm of its centre.
COUNTER_X = (0.20, 0.30, 0.40)
COUNTER_Y = (-0.30, -0.20, -0.10, 0.0, 0.10, 0.20, 0.30)
JITTER = 0.01
#: Closed rack centres: the dishwasher stands beyond the counter.
RACK_CENTRES = {TOP: (0.76, 0.0, 0.30), BOTTOM: (0.76, 0.0, 0.12)}
#: Dish centre above the rack centre, and the rows' x offsets (plates nearer the robot).
ROW_X = {PLATE: -0.035, BOWL: 0.035}
ROW_Z = {PLATE: 0.045, BOWL: 0.025}


def rack_slots(rack: str) -> list[Slot]:
    """A plate row and a bowl row of ``SLOTS_PER_ROW`` slots each, left (y < 0) to right."""
    slots = []
    for kind in (PLATE, BOWL):
        for i in range(SLOTS_PER_ROW):
            y = (i - (SLOTS_PER_ROW - 1) / 2) * SLOT_PITCH
            offset = np.array([ROW_X[kind], y, ROW_Z[kind]])
            slots.append(Slot(f"{rack.removeprefix('rack_')}_{kind}_{i:02d}", rack, kind, offset))
    return slots


@register_task("dishwasher")
class DishwasherLoading(DishwasherTask):
    """Dishwasher loading.

    **Task Description**: ``objects`` dishes (half plates, the rest bowls) lie on a counter;
    load them into a dishwasher with two racks (top, bottom), each with a row of plate slots
    and a row of bowl slots, as the ``preference`` says: ``top-bottom`` puts bowls in the top
    rack and plates in the bottom rack; ``left-right`` puts everything in the top rack, bowls
    on the right (y > 0), plates on the left. Plates stand upright (orientation 2), bowls
    upside down (1). A rack is loaded only when pulled out; the bottom rack only while the
    top one is pushed in; a slot holds one dish.

    **Randomizations**: the dishes' counter positions (random cells of a 10 cm grid,
    jittered) and their orientations (any of the six); which dishes are plates is fixed
    (``plate_*``, ``bowl_*``).

    **Success Conditions**: every dish stands in a slot its preference allows, in that slot's
    orientation, and both racks are pushed in.
    """

    def validate(self) -> None:
        if not 1 <= self.objects <= MAX_DISHES:
            raise TaskError(f"objects: must be in 1..{MAX_DISHES}")
        Preference.parse(self.params.preference)

    @property
    def objects(self) -> int:
        return self.params.objects or 10

    def layout(self, rng: np.random.Generator) -> DishwasherLayout:
        n = self.objects
        plates = (n + 1) // 2
        cells = [np.array([x, y]) for x in COUNTER_X for y in COUNTER_Y]
        chosen = rng.choice(len(cells), size=n, replace=False)
        sites = [cells[int(c)] + rng.uniform(-JITTER, JITTER, 2) for c in chosen]
        dishes = []
        for i, site in enumerate(sites):
            kind, number = (PLATE, i) if i < plates else (BOWL, i - plates)
            dish = Dish(f"{kind}_{number}", kind, np.zeros(3), int(rng.integers(6)))
            dish.position = np.array([site[0], site[1], resting_height(dish)])
            dishes.append(dish)
        racks = [Rack(rack, np.array(centre)) for rack, centre in RACK_CENTRES.items()]
        slots = rack_slots(TOP) + rack_slots(BOTTOM)
        racks_by_id = {rack.id: rack for rack in racks}
        return DishwasherLayout(
            # The generic view of the same episode (what tools that list bodies and goals see):
            # the dishes where they start, the slots where they are with both racks in.
            bodies=[Body(d.id, d.kind, d.size, d.position.copy()) for d in dishes],
            goals=[Goal(s.id, s.kind, racks_by_id[s.rack].centre + s.offset) for s in slots],
            dishes=dishes,
            racks=racks,
            slots=slots,
            preference=Preference.parse(self.params.preference),
        )

    def max_steps(self, goals: int) -> int:
        """Two steps per dish and four rack toggles, doubled for slack (``goals``: dishes)."""
        return 2 * (goals + 4)
