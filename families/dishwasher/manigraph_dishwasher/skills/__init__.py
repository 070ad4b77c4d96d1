"""The dishwasher family's skill extensions: its tray actions (the family action ``toggle``,
:mod:`.trays`, the drivers' ``toggle_tray``), its loading rules checked before a dish is moved
(``manigraph_dishwasher.rules``), where in its slot a bowl is set down (:mod:`.slot_room`), its
racks' floors and handles as obstacles (:mod:`.obstacles`) and turning a dish over on the
counter (which tilts, :mod:`.turn_over`; the Panda drivers' manoeuvre from the driver's public
pieces, :mod:`.panda_turn_over`)."""

from manigraph_dishwasher.fixtures import TOGGLE
from manigraph_dishwasher.rules import is_dishwasher_scene
from manigraph_shared.messages import Action
from manigraph_skills.family import SkillFamily


def _is_tray_action(action: Action) -> bool:
    return action.family_action == TOGGLE


_HERE = "manigraph_dishwasher.skills"
#: This family's skills part (its package's ``manigraph.families`` entry names it).
FAMILY = SkillFamily(
    name="dishwasher",
    matches=is_dishwasher_scene,
    takes=_is_tray_action,
    run_action=f"{_HERE}.trays:toggle_tray",
    check_move="manigraph_dishwasher.rules:check_dish_move",
    set_down_point=f"{_HERE}.slot_room:set_down_point",
    obstacles=f"{_HERE}.obstacles:rack_obstacles",
    turn_over=f"{_HERE}.panda_turn_over:turn_dish",
    help="tray actions, loading rules, slot room, rack obstacles, turn-over",
)
