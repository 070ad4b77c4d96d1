"""The dishwasher family's planner (docs/dishwasher.md): its expert (:mod:`.expert`,
registered as ``dishwasher-top-bottom`` and ``dishwasher-left-right``), its graph state
(:mod:`.features`), its four-headed network and ensemble (:mod:`.net`, :mod:`.ensemble`),
the policy that decodes them (:mod:`.gnn_policy`) and their training (the
training part, ``manigraph_dishwasher.training``), declared below as one
:class:`~manigraph_planner.family.PlannerFamily`.
"""

from manigraph_dishwasher.planner import expert  # noqa: F401  (registers its experts)
from manigraph_dishwasher.preference import EXPERTS, expert_name
from manigraph_dishwasher.rules import is_dishwasher_scene
from manigraph_planner.family import PlannerFamily
from manigraph_shared.messages import EpisodeRequest


def _expert_of(request: EpisodeRequest) -> str:
    """The expert of the request's preference option (:func:`..preference.expert_name`)."""
    preference = request.options.get("preference")
    return expert_name(preference if isinstance(preference, str) else None)


#: This family's planner part (its package's ``manigraph.families`` entry names it).
FAMILY = PlannerFamily(
    name="dishwasher",
    heads="dishwasher",
    experts=tuple(EXPERTS.values()),
    expert_of=_expert_of,
    matches=is_dishwasher_scene,
    feature_spec="manigraph_dishwasher.planner.features:DISH_FEATURE_SPEC",
    network="manigraph_dishwasher.planner.ensemble:dish_network",
    policy="manigraph_dishwasher.planner.gnn_policy:DishwasherGNNPolicy",
    train_command="manigraph_dishwasher.training.train_command:train_from_args",
    ensembles=True,
    help="dishes into racks: object, goal, orientation and tray-action heads",
)
