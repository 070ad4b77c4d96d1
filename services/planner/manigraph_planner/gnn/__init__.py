"""GNN task policies of the paper: graph state, networks, selection/loss, checkpoints."""

from manigraph_planner.gnn.checkpoint import (
    CheckpointInfo,
    LoadedCheckpoint,
    load_checkpoint,
    save_checkpoint,
)
from manigraph_planner.gnn.features import (
    FEATURE_SPEC,
    FeatureSpec,
    GraphState,
    fully_connected_edge_index,
    graph_from_arrays,
    scene_to_graph,
)
from manigraph_planner.gnn.models import ARCHITECTURES, ModelConfig, PolicyNet
from manigraph_planner.gnn.selection import (
    padded_select,
    padded_selection_loss,
    padded_split_logits,
    select,
    selection_loss,
    split_logits,
)

__all__ = [
    "ARCHITECTURES",
    "FEATURE_SPEC",
    "CheckpointInfo",
    "FeatureSpec",
    "GraphState",
    "LoadedCheckpoint",
    "ModelConfig",
    "PolicyNet",
    "fully_connected_edge_index",
    "graph_from_arrays",
    "load_checkpoint",
    "padded_select",
    "padded_selection_loss",
    "padded_split_logits",
    "save_checkpoint",
    "scene_to_graph",
    "select",
    "selection_loss",
    "split_logits",
]
