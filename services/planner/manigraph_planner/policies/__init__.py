"""Task policies: registered, swappable parts the planner serves. Each task family registers
its experts (``families/<name>/``); importing this package imports them all."""

from manigraph_planner import families  # noqa: F401  (registers each family's experts)
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
