"""Task policies: registered, swappable parts the planner serves."""

from manigraph_planner.dishwasher import expert as _dishwasher  # noqa: F401  (registers)
from manigraph_planner.policies import expert  # noqa: F401  (registers its policy)
from manigraph_planner.policies.base import (
    POLICIES,
    POLICY_FILE_LOADERS,
    Decision,
    Policy,
    load_policy,
    register_policy,
)

__all__ = [
    "POLICIES",
    "POLICY_FILE_LOADERS",
    "Decision",
    "Policy",
    "load_policy",
    "register_policy",
]
