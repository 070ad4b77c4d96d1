"""GNN policy networks; importing this package registers every architecture."""

from manigraph_planner.gnn.models import gat, gated, gcn, sage  # noqa: F401  (register)
from manigraph_planner.gnn.models.backbone import (
    ARCHITECTURES,
    Backbone,
    ConvStack,
    register_architecture,
)
from manigraph_planner.gnn.models.config import ModelConfig
from manigraph_planner.gnn.models.policy_net import PolicyNet

__all__ = [
    "ARCHITECTURES",
    "Backbone",
    "ConvStack",
    "ModelConfig",
    "PolicyNet",
    "register_architecture",
]
