"""Why did the policy choose that? The paper's modified GNNExplainer and its readable output.

Names are imported on first use (module ``__getattr__``): the planner service imports the
handler whatever policy it serves, and only a GNN policy's explanation needs torch.
"""

from __future__ import annotations

from importlib import import_module
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from manigraph_planner.explain.config import ExplainerConfig
    from manigraph_planner.explain.handler import ExplainHandler
    from manigraph_planner.explain.masks import MaskExplainer, MaskExplanation
    from manigraph_planner.explain.scene_explainer import SceneExplainer, sentence, to_message

_WHERE = {
    "ExplainHandler": "handler",
    "ExplainerConfig": "config",
    "MaskExplainer": "masks",
    "MaskExplanation": "masks",
    "SceneExplainer": "scene_explainer",
    "sentence": "scene_explainer",
    "to_message": "scene_explainer",
}

__all__ = [
    "ExplainHandler",
    "ExplainerConfig",
    "MaskExplainer",
    "MaskExplanation",
    "SceneExplainer",
    "sentence",
    "to_message",
]


def __getattr__(name: str) -> Any:
    if name not in _WHERE:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    return getattr(import_module(f"{__name__}.{_WHERE[name]}"), name)
