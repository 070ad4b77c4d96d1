"""Why did the policy choose that? The paper's modified GNNExplainer and its readable output.

Import this package only where torch may be imported (a GNN policy is being served).
"""

from manigraph_planner.explain.config import ExplainerConfig
from manigraph_planner.explain.handler import ExplainHandler
from manigraph_planner.explain.masks import MaskExplainer, MaskExplanation
from manigraph_planner.explain.scene_explainer import SceneExplainer, sentence, to_message

__all__ = [
    "ExplainHandler",
    "ExplainerConfig",
    "MaskExplainer",
    "MaskExplanation",
    "SceneExplainer",
    "sentence",
    "to_message",
]
