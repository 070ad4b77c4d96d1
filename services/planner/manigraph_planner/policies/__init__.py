"""Task policies: registered, swappable parts the planner serves."""

from manigraph_planner.policies import (
    expert,  # noqa: F401  (registers "expert")
    gnn,  # noqa: F401
)
from manigraph_planner.policies.base import POLICIES, Decision, Policy, load_policy, register_policy

__all__ = ["POLICIES", "Decision", "Policy", "load_policy", "register_policy"]
