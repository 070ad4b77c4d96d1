"""The dishwasher family: plates and bowls loaded into a two-rack dishwasher by a loading
preference, as one package (docs/dishwasher.md, docs/families.md).

Its parts: ``sim`` (its task, worlds and success check), ``planner`` (its experts, graph
state, four-headed network and its own training), ``skills`` (tray actions, loading rules,
slot room, rack obstacles, turn-over), ``tools`` (its episodes sized by their dishes and
preference), and ``manigraph dishwasher-experiment``
(:mod:`.commands.dishwasher_experiment`). Each service finds its part through :data:`PARTS`,
which this package's ``manigraph.families`` entry point names.
"""

#: Where each service finds this family's part (``"module:attribute"``), imported only when
#: that service first reads its family registry.
PARTS = {
    "sim": "manigraph_dishwasher.sim.family:DishwasherFamily",
    "planner": "manigraph_dishwasher.planner:FAMILY",
    "skills": "manigraph_dishwasher.skills:FAMILY",
    "tools": "manigraph_dishwasher.tools:FAMILY",
}
