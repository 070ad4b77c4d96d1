"""The dishwasher task's planner (docs/dishwasher.md): its expert (:mod:`.expert`, registered
as ``dishwasher-top-bottom`` and ``dishwasher-left-right``), its graph state
(:mod:`.features`), its four-headed network and ensemble (:mod:`.net`, :mod:`.ensemble`),
the policy that decodes them (:mod:`.gnn_policy`) and their training (:mod:`.training`,
:mod:`.augment`). The block task's counterparts live in ``gnn/``, ``policies/`` and
``training/``; the registries point here (``policies/__init__.py``,
``gnn/models/config.HEADS``, ``gnn/models/build.policy_net_for``)."""
