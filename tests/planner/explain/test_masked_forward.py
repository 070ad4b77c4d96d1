"""The explainer's dense masked network computes what PyG's explain hooks compute, without
importing PyG."""

from __future__ import annotations

import subprocess
import sys

import pytest
import torch

from manigraph_planner.explain.masked_forward import MaskedNet
from manigraph_planner.gnn.features import fully_connected_edge_index
from manigraph_planner.gnn.models import ModelConfig, PolicyNet

ARCHS = ("gcn", "sage", "gated", "gat")


def pyg_masked_logits(
    net: PolicyNet, x: torch.Tensor, edge_index: torch.Tensor, mask: torch.Tensor
):
    from torch_geometric.explain.algorithm.utils import clear_masks, set_masks

    set_masks(net, mask, edge_index, apply_sigmoid=False)
    try:
        return net(x, edge_index)
    finally:
        clear_masks(net)


@pytest.mark.parametrize("arch", ARCHS)
def test_masked_logits_and_their_gradients_equal_pyg_s_explain_hooks(arch: str) -> None:
    torch.manual_seed(3)
    pyg = PolicyNet(ModelConfig(arch)).eval()
    weights_only = PolicyNet(ModelConfig(arch), message_passing=False).eval()
    weights_only.load_state_dict(pyg.state_dict(), strict=True)
    x = torch.rand(7, pyg.config.input_size)
    edge_index = fully_connected_edge_index(7)
    logits = torch.randn(edge_index.shape[1])
    dense_logits = logits.clone().requires_grad_()
    dense = MaskedNet(weights_only)(x, edge_index, dense_logits.sigmoid())
    assert dense.shape == (7,)
    pyg.requires_grad_(False)
    pyg_logits = logits.clone().requires_grad_()
    expected = pyg_masked_logits(pyg, x, edge_index, pyg_logits.sigmoid())
    assert torch.allclose(dense, expected, atol=1e-5)
    dense.sum().backward()
    expected.sum().backward()
    assert torch.allclose(dense_logits.grad, pyg_logits.grad, atol=1e-5)
    with torch.no_grad():  # unmasked and all-ones masks are the policy's own logits
        plain = weights_only.forward_complete(x)
        assert torch.allclose(MaskedNet(weights_only)(x, edge_index, None), plain, atol=1e-5)
        ones = torch.ones(edge_index.shape[1])
        assert torch.allclose(MaskedNet(weights_only)(x, edge_index, ones), plain, atol=1e-5)


def test_a_served_checkpoint_is_explained_without_importing_pyg(tmp_path) -> None:
    """In a fresh process, like the planner: loading, building the explainer and explaining
    leave ``torch_geometric`` unimported."""
    script = """
import sys, torch
from manigraph_planner.gnn.models import ModelConfig, PolicyNet
from manigraph_planner.policies.gnn import GNNPolicy
from manigraph_planner.explain.scene_explainer import SceneExplainer
from manigraph_shared.messages import Scene, SceneGoal, SceneObject, Vector3
size = Vector3(x=0.04, y=0.04, z=0.04)
objects = [SceneObject(id=f"b{i}", category="block", position=Vector3(x=0.5, y=0.1 * i, z=0.02),
           size=size) for i in range(3)]
goals = [SceneGoal(id=f"g{i}", category="block", position=Vector3(x=0.3, y=0.1 * i, z=0.02))
         for i in range(3)]
scene = Scene(episode_id="e", stamp=1.0, sequence=0, objects=objects, goals=goals)
for arch in ("gcn", "sage", "gated", "gat"):
    policy = GNNPolicy(PolicyNet(ModelConfig(arch), message_passing=False))
    SceneExplainer(policy).explain_scene(scene)
print("pyg" if "torch_geometric" in sys.modules else "no pyg")
"""
    done = subprocess.run(
        [sys.executable, "-c", script], capture_output=True, text=True, timeout=300, check=True
    )
    assert done.stdout.strip().splitlines()[-1] == "no pyg", done.stderr
