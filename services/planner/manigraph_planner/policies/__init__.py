"""Task policies: registered, swappable parts the planner serves."""

from manigraph_planner.policies import (  # noqa: F401  (register their policies)
    dishwasher_expert,
    expert,
)
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
