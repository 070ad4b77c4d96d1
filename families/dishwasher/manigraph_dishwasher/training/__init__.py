"""The dishwasher family's training part (docs/dishwasher.md, docs/training.md): its four-headed
imitation loop (:mod:`.loop`), the augmentation it draws with (:mod:`.augment`), and what
``manigraph train`` runs for dishwasher demonstrations (:mod:`.train_command`, named by its
``PlannerFamily.train_command``). It imports the training package (``manigraph_training``):
the serving planner never loads it."""
