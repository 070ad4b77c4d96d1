"""The paper's reinforcement-learning baselines on K-block stacking (PPO, stable-baselines3).

Importing this package registers the Gymnasium environment ``manigraph/Stack-v0``::

    import gymnasium
    import manigraph_lab.rl  # noqa: F401  (registers manigraph/Stack-v0)

    env = gymnasium.make("manigraph/Stack-v0", blocks=4)
"""

import gymnasium

ENV_ID = "manigraph/Stack-v0"

if ENV_ID not in gymnasium.registry:
    gymnasium.register(id=ENV_ID, entry_point="manigraph_lab.rl.env:StackEnv")

__all__ = ["ENV_ID"]
