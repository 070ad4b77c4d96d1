r"""The paper's modified GNNExplainer: edge and feature masks for one whole-graph decision.

GNNExplainer (Ying et al., 2019) explains a per-node classification. The policy instead
reads *all* node logits as two distributions, one over the :math:`K` objects and one over the
:math:`L` goals, and the decision is the pair :math:`(o^*, g^*)`. So every node is kept
(:math:`G_S = (V, E_S)`) and the masks are fitted to that pair:

.. math::
    \min_{M_E, M_F}\;
        \underbrace{-\log p_S(o^*) - \log p_S(g^*)}_{H(Y \mid \pi_\theta(G_S, \phi_S))}
        + \lambda \big[\,\mathrm{relu}\big(\textstyle\sum_e \sigma(M_E)_e - c_E\big)
                      + \mathrm{relu}\big(\textstyle\sum_j \sigma(M_F)_j - c_F\big)\big]
        + \beta \big[\,\overline{H_b(\sigma(M_E))} + \overline{H_b(\sigma(M_F))}\,\big]

with :math:`p_S = \mathrm{softmax}` over the object (goal) nodes of
:math:`\pi_\theta(G_S, \phi \odot \sigma(M_F))`, every message along edge :math:`e`
multiplied by :math:`\sigma(M_E)_e` (PyG's explain hooks, so it works for any
``MessagePassing`` layer: GraphConv, SAGEConv, GatedGraphConv, GATConv), :math:`H_b` the
binary entropy pushing each mask value to 0 or 1, :math:`c_E, c_F` the budgets of the paper.
The first term is the paper's Eq. (red_mi) with the policy's own choice as the label (the
cross-entropy form GNNExplainer uses for :math:`H(Y \mid \cdot)`).

That is the ``distribution`` objective. It keeps the pair likely by any means, and with every
node kept, edges into the *competing* objects and goals move the two softmaxes as much as edges
into the chosen ones: its top edge often touches neither chosen node. The ``pair`` objective
(:class:`~manigraph_planner.explain.config.Objective`, the default) explains the choice
*against its runner-up*: with :math:`m_o = z_{o^*} - \max_{o \ne o^*} z_o` and
:math:`m_g` alike (node logits :math:`z`), only edges incident to :math:`o^*` or :math:`g^*`
may enter the explanation, and

.. math::
    \min\; \mathrm{softplus}(-m_o^{S}) + \mathrm{softplus}(-m_g^{S})
        + \gamma\,[\mathrm{softplus}(m_o^{C \setminus S}) + \mathrm{softplus}(m_g^{C \setminus S})]
        + \text{budgets} + \text{entropy}

where :math:`S` is the masked graph and :math:`C \setminus S` its complement (masks
:math:`1 - \sigma(M)`): the choice should hold on the explanation (fidelity-) and fall
without it (fidelity+), as PyG's ``fidelity`` measures them.

A network with a ``pairs`` decoder decides :math:`p(o)\,p(g \mid o)`
(:mod:`~manigraph_planner.gnn.pair_decoder`): the first term is then
:math:`-\log p_S(o^*) - \log p_S(g^* \mid o^*)`, and :math:`m_g` the chosen pair's score
over the best other goal's for the same object, :math:`s(o^*, g^*) - \max_{g \ne g^*}
s(o^*, g)`: what is explained is the chosen pair's score.

After ``steps`` Adam steps the explanation keeps the top-:math:`c_E` edges and the
top-:math:`c_F` features (hard masks); every edge and feature stays ranked. The initial mask
logits come from a seeded generator and the optimisation is plain CPU arithmetic, so the
same seed, graph and network give the same explanation.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass

import torch
from torch import Tensor

from manigraph_planner.explain.config import ExplainerConfig, Objective
from manigraph_planner.explain.masked_forward import MaskedNet
from manigraph_planner.gnn.models import PolicyNet
from manigraph_planner.gnn.pair_decoder import category_compatible
from manigraph_shared.errors import PolicyError

__all__ = ["MaskExplainer", "MaskExplanation"]

_EPS = 1e-6


@dataclass(frozen=True)
class MaskExplanation:
    """Soft masks after optimisation and the hard explanation they give.

    Shapes:
        - **edge_index:** :math:`(2, E)` the explained graph's edges (source, target)
        - **edge_mask:** :math:`(E,)` :math:`\\sigma(M_E)` in [0, 1]
        - **feature_mask:** :math:`(F,)` :math:`\\sigma(M_F)` in [0, 1]
        - **edge_order / feature_order:** every edge (feature) index, strongest first
    """

    object_index: int
    goal_index: int
    edge_index: Tensor
    edge_mask: Tensor
    feature_mask: Tensor
    edge_order: Tensor
    feature_order: Tensor
    edge_budget: int
    feature_budget: int
    fidelity: float
    loss: float

    @property
    def kept_edges(self) -> Tensor:
        """Indices of the :math:`\\le c_E` edges of :math:`E_S`, strongest first."""
        return self.edge_order[: self.edge_budget]

    @property
    def kept_features(self) -> Tensor:
        """Indices of the :math:`\\le c_F` alive features, strongest first."""
        return self.feature_order[: self.feature_budget]


class MaskExplainer:
    """Fits edge and feature masks that keep a trained policy's (object, goal) choice.

    Works on a private frozen copy of ``net``, so explaining never disturbs (and is never
    disturbed by) the policy deciding on the original at the same time.

    Args:
        net: a trained :class:`PolicyNet`.
        config: steps, budgets, penalty weights, default seed.
    """

    def __init__(self, net: PolicyNet, config: ExplainerConfig | None = None) -> None:
        self.config = config or ExplainerConfig()
        self.net = MaskedNet(net)
        #: A ``pairs`` decoder's goals that fit the chosen object's category, set per
        #: :meth:`explain` from the unmasked categories (as the policy reads them).
        self._fitting_goals: Tensor | None = None

    def explain(
        self,
        x: Tensor,
        edge_index: Tensor,
        num_objects: int,
        object_index: int,
        goal_index: int,
        seed: int | None = None,
        deadline: float | None = None,
        steps: int | None = None,
    ) -> MaskExplanation:
        """Explain the choice of node ``object_index`` and node ``goal_index``.

        Args:
            x: node features, objects first (nodes ``0 .. num_objects - 1``), then goals.
            edge_index: the graph's edges.
            num_objects: :math:`K`.
            object_index, goal_index: the chosen nodes (``goal_index >= num_objects``).
            seed: overrides the config's seed.
            deadline: ``time.monotonic()`` after which the optimisation is abandoned.
            steps: overrides the config's steps (the warm-up's two).

        Shapes:
            - **x:** :math:`(N, F)`; **edge_index:** :math:`(2, E)`

        Raises:
            PolicyError: the indices do not name an object and a goal of this graph, or the
                graph has no edges, or the deadline passed (``explain_deadline``).
        """
        num_nodes = int(x.shape[0])
        _check_indices(num_nodes, num_objects, object_index, goal_index, int(edge_index.shape[1]))
        cfg = self.config
        steps = cfg.steps if steps is None else steps
        generator = torch.Generator().manual_seed(cfg.seed if seed is None else seed)
        num_edges, num_features = int(edge_index.shape[1]), int(x.shape[1])
        std = torch.nn.init.calculate_gain("relu") * math.sqrt(2.0 / (2 * num_nodes))
        edge_logits = torch.randn(num_edges, generator=generator) * std + cfg.initial_edge_logit
        edge_logits.requires_grad_()
        pair = cfg.objective is not Objective.DISTRIBUTION
        everything = torch.ones(num_edges, dtype=torch.bool)
        # pair objectives show only edges incident to the chosen nodes; "pair" also keeps the
        # rest out of the masked graph, "pair-context" lets them in as (budgeted) context
        shown = _incident(edge_index, object_index, goal_index) if pair else everything
        candidates = shown if cfg.objective is Objective.PAIR else everything
        closed = torch.full((num_edges,), -30.0)
        feature_logits = (torch.randn(num_features, generator=generator) * 0.1).requires_grad_()
        edge_budget = min(cfg.edge_budget, num_edges)
        feature_budget = min(cfg.feature_budget, num_features)
        optimiser = _Adam([edge_logits, feature_logits], cfg.learning_rate)
        x = x.detach().to(torch.float32)
        self._fitting_goals = _fitting_goals(x, num_objects, object_index)
        loss_value = float("nan")
        with torch.inference_mode(False), torch.enable_grad():
            for step in range(steps):
                if deadline is not None and time.monotonic() > deadline:
                    raise PolicyError(
                        f"explain_deadline: gave up after {step} of {steps} steps "
                        f"({num_nodes} nodes, {num_edges} edges)"
                    )
                optimiser.zero_grad()
                edge_mask = torch.where(candidates, edge_logits, closed).sigmoid()
                feature_mask = feature_logits.sigmoid()
                choice = (self._margins if pair else self._log_choice)(
                    x * feature_mask, edge_index, edge_mask, num_objects, object_index, goal_index
                )
                if pair:
                    rest = self._margins(
                        x * (1.0 - feature_mask),
                        edge_index,
                        1.0 - edge_mask,
                        num_objects,
                        object_index,
                        goal_index,
                    )
                    fit = torch.nn.functional.softplus(-choice).sum()
                    fit = fit + cfg.complement_weight * torch.nn.functional.softplus(rest).sum()
                else:
                    fit = -choice
                edge_mass = edge_mask[candidates].sum()
                over = (edge_mass - edge_budget).relu() + (
                    feature_mask.sum() - feature_budget
                ).relu()
                undecided = _binary_entropy(edge_mask[candidates]) + _binary_entropy(feature_mask)
                loss = fit + cfg.budget_weight * over + cfg.entropy_weight * undecided
                loss.backward()
                optimiser.step()
                loss_value = float(loss.detach())
        edge_mask = torch.where(candidates, edge_logits.detach(), closed).sigmoid()
        feature_mask = feature_logits.detach().sigmoid()
        edge_order = torch.sort(edge_mask + shown.float(), descending=True, stable=True).indices
        feature_order = torch.sort(feature_mask, descending=True, stable=True).indices
        kept = (edge_order[:edge_budget], feature_order[:feature_budget])
        fidelity = self._fidelity(x, edge_index, num_objects, object_index, goal_index, *kept)
        return MaskExplanation(
            object_index=object_index,
            goal_index=goal_index,
            edge_index=edge_index,
            edge_mask=edge_mask,
            feature_mask=feature_mask,
            edge_order=edge_order,
            feature_order=feature_order,
            edge_budget=edge_budget,
            feature_budget=feature_budget,
            fidelity=fidelity,
            loss=loss_value,
        )

    def _log_choice(
        self,
        x: Tensor,
        edge_index: Tensor,
        edge_mask: Tensor | None,
        num_objects: int,
        object_index: int,
        goal_index: int,
    ) -> Tensor:
        """:math:`\\log p(o^*) + \\log p(g^*)` with messages scaled by ``edge_mask``."""
        logits = self.net(x, edge_index, edge_mask)
        object_logp = logits[:num_objects].log_softmax(0)[object_index]
        if self.net.decodes_pairs:
            goals = self._goal_scores(x, num_objects, object_index)
            return object_logp + goals.log_softmax(0)[goal_index - num_objects]
        goal_logp = logits[num_objects:].log_softmax(0)[goal_index - num_objects]
        return object_logp + goal_logp

    def _margins(
        self,
        x: Tensor,
        edge_index: Tensor,
        edge_mask: Tensor | None,
        num_objects: int,
        object_index: int,
        goal_index: int,
    ) -> Tensor:
        """:math:`(m_o, m_g)`: the chosen object's (goal's) logit over the best other one's
        (0 when it has no rival)."""
        logits = self.net(x, edge_index, edge_mask)
        goals = (
            self._goal_scores(x, num_objects, object_index)
            if self.net.decodes_pairs
            else logits[num_objects:]
        )
        return torch.stack(
            [
                _margin(logits[:num_objects], object_index),
                _margin(goals, goal_index - num_objects),
            ]
        )

    def _goal_scores(self, x: Tensor, num_objects: int, object_index: int) -> Tensor:
        """A ``pairs`` decoder's scores :math:`s(o^*, g)` of every goal for the chosen object,
        the lowest finite float for goals of another category. Shape :math:`(L,)`."""
        scores = self.net.pair_logits(x)[object_index, num_objects:]
        fitting = self._fitting_goals
        if fitting is None:
            fitting = _fitting_goals(x, num_objects, object_index)
        return scores.masked_fill(~fitting, torch.finfo(scores.dtype).min)

    def _fidelity(
        self,
        x: Tensor,
        edge_index: Tensor,
        num_objects: int,
        object_index: int,
        goal_index: int,
        kept_edges: Tensor,
        kept_features: Tensor,
    ) -> float:
        """:math:`p(o^*)\\,p(g^*)` with only the kept edges and features alive (hard masks)."""
        hard_edges = torch.zeros(edge_index.shape[1])
        hard_edges[kept_edges] = 1.0
        hard_features = torch.zeros(x.shape[1])
        hard_features[kept_features] = 1.0
        with torch.no_grad():
            log_p = self._log_choice(
                x * hard_features, edge_index, hard_edges, num_objects, object_index, goal_index
            )
        return min(1.0, max(0.0, float(log_p.exp())))


class _Adam:
    """Adam (Kingma and Ba, 2015) with torch's defaults (betas 0.9 and 0.999, eps 1e-8), the
    same steps as ``torch.optim.Adam``: that class imports ``torch._dynamo`` when first built,
    a second of a fresh planner's time (the explainer is warmed right after the start)."""

    def __init__(self, params: list[Tensor], lr: float) -> None:
        self.params, self.lr, self.steps = params, lr, 0
        self.first = [torch.zeros_like(p) for p in params]
        self.second = [torch.zeros_like(p) for p in params]

    def zero_grad(self) -> None:
        for param in self.params:
            param.grad = None

    @torch.no_grad()
    def step(self) -> None:
        self.steps += 1
        beta1, beta2 = 0.9, 0.999
        step_size = self.lr / (1 - beta1**self.steps)
        root_correction = math.sqrt(1 - beta2**self.steps)
        for param, first, second in zip(self.params, self.first, self.second, strict=True):
            if param.grad is None:
                continue
            grad = param.grad
            first.lerp_(grad, 1 - beta1)
            second.mul_(beta2).addcmul_(grad, grad, value=1 - beta2)
            denominator = (second.sqrt() / root_correction).add_(1e-8)
            param.addcdiv_(first, denominator, value=-step_size)


def _fitting_goals(x: Tensor, num_objects: int, object_index: int) -> Tensor:
    """``(L,)``: the goals whose category fits the chosen object's."""
    chosen = x[object_index : object_index + 1, 0]
    return category_compatible(chosen, x[num_objects:, 0])[0]


def _margin(logits: Tensor, index: int) -> Tensor:
    if logits.shape[0] < 2:
        return logits.new_zeros(())
    others = torch.cat([logits[:index], logits[index + 1 :]])
    return logits[index] - others.max()


def _incident(edge_index: Tensor, object_index: int, goal_index: int) -> Tensor:
    """Edges that start or end on the chosen object or goal."""
    ends = torch.tensor([object_index, goal_index])
    return torch.isin(edge_index[0], ends) | torch.isin(edge_index[1], ends)


def _binary_entropy(mask: Tensor) -> Tensor:
    m = mask.clamp(_EPS, 1 - _EPS)
    return -(m * m.log() + (1 - m) * (1 - m).log()).mean()


def _check_indices(
    num_nodes: int, num_objects: int, object_index: int, goal_index: int, num_edges: int
) -> None:
    if not 0 < num_objects < num_nodes:
        raise PolicyError(
            f"num_objects: a graph of {num_nodes} nodes needs 1..{num_nodes - 1} objects, "
            f"got {num_objects}"
        )
    if not 0 <= object_index < num_objects:
        raise PolicyError(f"object_index: must be in 0..{num_objects - 1}, got {object_index}")
    if not num_objects <= goal_index < num_nodes:
        raise PolicyError(
            f"goal_index: must be in {num_objects}..{num_nodes - 1}, got {goal_index}"
        )
    if num_edges == 0:
        raise PolicyError("edge_index: the graph has no edges to explain")
