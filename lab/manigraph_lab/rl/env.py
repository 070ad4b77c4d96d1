r"""K-block stacking as a Gymnasium environment: the paper's state, action and dense reward.

**Task**: the geometric world's ``stack`` task (K blocks in one stack; build the inverted
stack elsewhere), exactly what ``manigraph eval --task stack`` plays, through the same
``Scene`` and ``RobotCommand`` messages (:mod:`manigraph_lab.episode_loop`).

**State**: the planner's graph state (:func:`~manigraph_planner.gnn.features.scene_to_graph`,
5 features per node: category, x, y, z, filled), laid into fixed slots so the space has one
shape: objects in slots ``0 .. M-1``, goals in slots ``M .. 2M-1`` (``M = max_blocks``), zero
rows where a slot is empty, and ``node_mask`` 1 for real nodes.

**Action**: one ``(object, goal)`` pair, ``action = object_slot * M + goal_slot``;
:meth:`StackEnv.action_masks` allows the pairs of real, category-compatible nodes (a block to
a block goal, a cover to a cover goal), as ``sb3_contrib.MaskablePPO`` expects. A masked-out
pair (a random agent, ``check_env``) is a failed step that changes nothing.

**Reward** (the paper):

.. math::
    r_t = \frac{g(s_t) - g(s_{t-1})}{G}

with :math:`g` the goals filled and :math:`G` all goals, so a successful episode returns 1.0
(an action that un-fills a goal costs what it took). The episode terminates when every goal
is filled and is truncated when the task's step budget (``2 G + 4`` PickAndPlace attempts) is
spent; failed attempts (a covered block) count, as in evaluation.

Training episodes draw their layout seeds from ``TRAIN_SEED_BASE`` up, so they never repeat
an evaluation episode (seeds 0, 1, ...).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import gymnasium
import numpy as np
from gymnasium import spaces

from manigraph_lab.episode_loop import StepClock, in_process_skill
from manigraph_planner.gnn.features import FEATURE_SPEC, GraphState, scene_to_graph
from manigraph_planner.policies.base import Decision
from manigraph_shared.errors import ConfigError
from manigraph_shared.messages import EpisodeRequest, Scene, SkillState
from manigraph_sim.geometric.backend import GeometricBackend

__all__ = ["TRAIN_SEED_BASE", "SlotLayout", "StackEnv"]

#: Training episodes use layout seeds >= this; evaluation uses 0, 1, ...
TRAIN_SEED_BASE = 1_000_000

#: Bound of every observed number: positions in metres stay far inside it, codes are 0..3.
_BOUND = 100.0

#: Object category code -> the goal category code it fills (block -> block goal, ...).
_FILLS = {
    FEATURE_SPEC.code("block"): FEATURE_SPEC.code("block-goal"),
    FEATURE_SPEC.code("cover"): FEATURE_SPEC.code("cover-goal"),
}


@dataclass(frozen=True)
class SlotLayout:
    """Where a graph's nodes go in a fixed-size observation, and what an action index means.

    Shapes:
        - **nodes:** :math:`(M_o + M_g, 5)` float32, objects in the first :math:`M_o` slots
        - **node_mask:** :math:`(M_o + M_g,)` float32, 1 for real nodes
        - **action mask:** :math:`(M_o M_g,)` bool, entry :math:`o M_g + g`
    """

    max_objects: int
    max_goals: int

    @property
    def num_nodes(self) -> int:
        return self.max_objects + self.max_goals

    @property
    def num_actions(self) -> int:
        return self.max_objects * self.max_goals

    def pair(self, action: int) -> tuple[int, int]:
        """``(object index, goal index)`` of ``action`` within the graph."""
        return divmod(int(action), self.max_goals)

    def encode(self, graph: GraphState) -> tuple[dict[str, np.ndarray], np.ndarray]:
        """The observation of ``graph`` and its action mask.

        Raises:
            ConfigError: the graph has more objects or goals than there are slots.
        """
        k, n = graph.num_objects, graph.num_nodes
        if k > self.max_objects or n - k > self.max_goals:
            raise ConfigError(
                "max_blocks",
                f"a scene with {k} objects and {n - k} goals does not fit "
                f"{self.max_objects} object and {self.max_goals} goal slots",
            )
        x = graph.x.numpy()
        nodes = np.zeros((self.num_nodes, x.shape[1]), dtype=np.float32)
        node_mask = np.zeros(self.num_nodes, dtype=np.float32)
        nodes[:k], node_mask[:k] = x[:k], 1.0
        nodes[self.max_objects : self.max_objects + n - k] = x[k:]
        node_mask[self.max_objects : self.max_objects + n - k] = 1.0
        fills = np.array([_FILLS.get(int(np.rint(c)), -1) for c in x[:k, 0]])
        compatible = fills[:, None] == np.rint(x[k:, 0])[None, :]
        action_mask = np.zeros((self.max_objects, self.max_goals), dtype=bool)
        action_mask[:k, : n - k] = compatible
        return {"nodes": nodes, "node_mask": node_mask}, action_mask.reshape(-1)

    def observation_space(self) -> spaces.Dict:
        return spaces.Dict(
            {
                "nodes": spaces.Box(-_BOUND, _BOUND, (self.num_nodes, 5), np.float32),
                "node_mask": spaces.Box(0.0, 1.0, (self.num_nodes,), np.float32),
            }
        )


class StackEnv(gymnasium.Env[dict[str, np.ndarray], np.int64]):
    """K-block stacking in the geometric world (see the module docstring).

    Args:
        blocks: K, or several: each episode then draws its K uniformly (mixed training).
        max_blocks: slots for objects and for goals (default: the largest K), so envs of
            different K can share one observation and action space.

    Raises:
        ConfigError: ``blocks`` empty or outside 1..64, or larger than ``max_blocks``.
    """

    metadata: dict[str, Any] = {"render_modes": []}

    def __init__(self, blocks: int | Sequence[int] = 3, max_blocks: int | None = None) -> None:
        ks = (blocks,) if isinstance(blocks, int) else tuple(int(k) for k in blocks)
        if not ks or not all(1 <= k <= 64 for k in ks):
            raise ConfigError("blocks", f"each K must be in 1..64, got {blocks!r}")
        slots = max(ks) if max_blocks is None else max_blocks
        if slots < max(ks):
            raise ConfigError("max_blocks", f"must be >= the largest K {max(ks)}, got {slots}")
        self.blocks = ks
        self.layout = SlotLayout(slots, slots)
        self.observation_space = self.layout.observation_space()  # type: ignore[assignment]
        self.action_space = spaces.Discrete(self.layout.num_actions)
        self.backend = GeometricBackend()
        self._clock = StepClock()
        self._skill = in_process_skill(self.backend, self._clock)
        self._steps = 0
        self._filled = 0
        self._goals = 1
        self._scene: Scene | None = None
        self._graph: GraphState | None = None
        self._mask = np.zeros(self.layout.num_actions, dtype=bool)

    def reset(
        self, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[dict[str, np.ndarray], dict[str, Any]]:
        """Options: ``blocks`` (this episode's K) and ``episode_seed`` (its layout seed)."""
        super().reset(seed=seed)
        options = options or {}
        k = int(options.get("blocks", self.np_random.choice(self.blocks)))
        if not 1 <= k <= self.layout.max_objects:
            raise ConfigError("blocks", f"must be in 1..{self.layout.max_objects}, got {k}")
        episode_seed = options.get("episode_seed")
        if episode_seed is None:
            episode_seed = int(self.np_random.integers(TRAIN_SEED_BASE, 2**31 - 1))
        request = EpisodeRequest(
            episode_id=f"rl-stack-{k}-{episode_seed}",
            task="stack",
            blocks=k,
            seed=int(episode_seed),
        )
        self._clock.now = 0.0
        self.backend.reset(request, self._clock())
        self._steps = 0
        self._filled = self.backend.required_filled()
        self._goals = max(len(self.backend.required), 1)
        return self._observe(), {"blocks": k, "episode_seed": int(episode_seed)}

    @property
    def scene(self) -> Scene | None:
        """The ``Scene`` the latest observation was made from (None before ``reset``)."""
        return self._scene

    def action_of(self, object_id: str, goal_id: str) -> int:
        """The action index that moves ``object_id`` to ``goal_id`` in the latest observation
        (e.g. to replay the expert's decisions).

        Raises:
            ConfigError: either id is not a node of the latest observation.
        """
        if self._graph is None:
            raise RuntimeError("action_of() before reset()")
        if object_id not in self._graph.object_ids:
            raise ConfigError("object_id", f"'{object_id}' is not an observed object")
        if goal_id not in self._graph.goal_ids:
            raise ConfigError("goal_id", f"'{goal_id}' is not an observed goal")
        o, g = self._graph.object_ids.index(object_id), self._graph.goal_ids.index(goal_id)
        return o * self.layout.max_goals + g

    def action_masks(self) -> np.ndarray:
        """Allowed actions: real, category-compatible (object, goal) pairs."""
        return self._mask.copy()

    def step(
        self, action: np.int64 | int
    ) -> tuple[dict[str, np.ndarray], float, bool, bool, dict[str, Any]]:
        if self._scene is None or self._graph is None:
            raise RuntimeError("step() before reset()")
        index = int(action)
        self._steps += 1
        self._clock.now += 1.0
        if 0 <= index < self.layout.num_actions and self._mask[index]:
            o, g = self.layout.pair(index)
            decision = Decision(self._graph.object_ids[o], self._graph.goal_ids[g])
            message = decision.to_action(self._scene, self._steps - 1, "rl", self._clock())
            status = self._skill.execute(message, self._scene, self.backend.skill_finished)
            ok, reason = status.state is SkillState.SUCCEEDED, status.reason
        else:
            ok, reason = False, "masked_action"
        filled = self.backend.required_filled()
        reward = (filled - self._filled) / self._goals
        self._filled = filled
        terminated = filled == len(self.backend.required)
        truncated = not terminated and self._steps >= self.backend.max_steps
        info = {
            "ok": ok,
            "reason": reason,
            "goals_filled": filled,
            "goals": len(self.backend.required),
            "is_success": terminated,
        }
        return self._observe(), float(reward), terminated, truncated, info

    def _observe(self) -> dict[str, np.ndarray]:
        scene = self.backend.scene(self._clock())
        assert scene is not None
        self._scene = scene
        self._graph = scene_to_graph(scene)
        observation, self._mask = self.layout.encode(self._graph)
        return observation
