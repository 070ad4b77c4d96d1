"""The block family's training part (docs/training.md): its augmentation recipe per
architecture (:mod:`.recipes`, named by its ``PlannerFamily.recipe``), which the generic
trainer (``manigraph_training``) draws with, and the structural steps they use
(:mod:`.augment`, :mod:`.structure`, :mod:`.task_growth`). The serving planner never loads
it."""
