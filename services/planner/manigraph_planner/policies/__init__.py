"""Task policies: registered, swappable parts the planner serves. Each task family registers
its experts (its package's ``planner`` part), when ``POLICIES`` is first read."""

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
